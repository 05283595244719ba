// The interface between the shaders and the C++ that binds them, in one place: descriptor bindings,
// specialization-constant ids and the reduction record's size. Valid GLSL and C++ both: the shaders
// (#include "shader_interface.h") and src/gpu/vulkan_evaluator.cpp are compiled from these same macros, so a
// binding the two disagree on cannot be built.
#ifndef TSDF_MCL_SHADER_INTERFACE_H
#define TSDF_MCL_SHADER_INTERFACE_H

// endpoint_weight.comp: descriptor set 0.
#define EW_BINDING_PARTICLES 0
#define EW_BINDING_POINTS 1
#define EW_BINDING_COARSE 2
#define EW_BINDING_POOL0 3  // the block pool in up to EW_MAX_POOL_CHUNKS storage-buffer chunks: 3..6
#define EW_MAX_POOL_CHUNKS 4
#define EW_BINDING_UNIFORM_POINTS 7  // the points buffer again, as a uniform buffer
#define EW_BINDING_COARSE_VIEW 8     // texel-buffer views of the coarse index and the pool chunks: 8..12
#define EW_BINDING_POOL_VIEW0 9
#define EW_BINDING_TABLE_VIEW 13  // nearest lookup: per quantized distance, the point's term (float bits)
#define EW_BINDINGS 14

// endpoint_weight.comp: specialization constants.
#define EW_SPEC_WORKGROUP 0
#define EW_SPEC_INTERPOLATION 1
#define EW_SPEC_LIKELIHOOD 2
#define EW_SPEC_CHUNK_SHIFT 3
#define EW_SPEC_POOL_CHUNKS 4
#define EW_SPEC_UNIFORM_POINTS 5
#define EW_SPEC_UNIFORM_POINT_CAPACITY 6
#define EW_SPEC_MAP_TEXEL_VIEWS 7
#define EW_SPEC_BATCH 8
#define EW_SPEC_COUNT 9

// reduce.comp: descriptor set 0 and specialization constants.
#define RD_BINDING_PARTICLES 0
#define RD_BINDING_RECORDS_IN 1
#define RD_BINDING_RECORDS_OUT 2
#define RD_BINDINGS 3
#define RD_SPEC_WORKGROUP 0
#define RD_SPEC_ITEMS_PER_THREAD 1
#define RD_SPEC_COUNT 2
#define RD_RECORD_FLOATS 12  // m, s, px, py, pz, qw, qx, qy, qz, fit, pad, pad

#endif
