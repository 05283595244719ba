#include "compression.hpp"

#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <limits>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::rosbag2 {
namespace {

constexpr std::size_t kFirstGrowth = std::size_t{1} << 20;

// Runs `step(out, room, &produced, &consumed)` until the input is consumed and `step` says it is done, growing `out`
// by doubling (from 1 MiB) but never past declared + 1: one byte more than declared proves the data hold more.
template <typename Step>
void stream(std::size_t size, std::uint64_t declared, Decompressed& out, const std::string& what, Step&& step) {
  out.clear();
  std::size_t consumed = 0;
  for (;;) {
    if (out.size() == out.capacity()) {
      if (out.size() > declared) break;
      const std::uint64_t limit = declared + 1;
      out.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(limit, std::max(kFirstGrowth, 2 * out.capacity()))));
    }
    std::size_t produced = 0, used = 0;
    std::uint8_t* room = out.reserve(out.size() + 1);
    const bool done = step(room, out.capacity() - out.size(), consumed, &produced, &used);
    out.grew(produced);
    consumed += used;
    if (done && consumed == size) break;
    if (produced == 0 && used == 0) {
      throw Error(what + ": compressed data end inside a frame (" + std::to_string(out.size()) + " of " +
                  std::to_string(declared) + " bytes decompressed)");
    }
  }
  if (out.size() != declared) {
    throw Error(what + ": decompresses to " + (out.size() > declared ? "more than " : "") + std::to_string(out.size()) +
                " bytes, not the " + std::to_string(declared) + " it declares");
  }
}

void decompress_zstd(const std::uint8_t* data, std::size_t size, std::uint64_t declared, Decompressed& out,
                     const std::string& what) {
  const std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> context(ZSTD_createDCtx(), ZSTD_freeDCtx);
  if (!context) throw Error(what + ": cannot start a zstd decompression");
  stream(size, declared, out, what,
         [&](std::uint8_t* room, std::size_t n, std::size_t at, std::size_t* produced, std::size_t* used) {
           ZSTD_outBuffer o{room, n, 0};
           ZSTD_inBuffer i{data + at, size - at, 0};
           const std::size_t r = ZSTD_decompressStream(context.get(), &o, &i);
           if (ZSTD_isError(r)) throw Error(what + ": corrupt zstd data (" + ZSTD_getErrorName(r) + ")");
           *produced = o.pos;
           *used = i.pos;
           return r == 0;  // a frame complete; another may follow
         });
}

void decompress_lz4(const std::uint8_t* data, std::size_t size, std::uint64_t declared, Decompressed& out,
                    const std::string& what) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) {
    throw Error(what + ": cannot start an LZ4 decompression");
  }
  const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> context(raw,
                                                                                     LZ4F_freeDecompressionContext);
  stream(size, declared, out, what,
         [&](std::uint8_t* room, std::size_t n, std::size_t at, std::size_t* produced, std::size_t* used) {
           std::size_t in_n = size - at, out_n = n;
           const std::size_t hint = LZ4F_decompress(context.get(), room, &out_n, data + at, &in_n, nullptr);
           if (LZ4F_isError(hint)) throw Error(what + ": corrupt LZ4 data (" + LZ4F_getErrorName(hint) + ")");
           *produced = out_n;
           *used = in_n;
           return hint == 0;  // a frame complete
         });
}

}  // namespace

std::uint8_t* Decompressed::reserve(std::size_t n) {
  if (n > capacity_) {
    std::unique_ptr<std::uint8_t[]> bigger(new std::uint8_t[n]);
    if (size_ > 0) std::memcpy(bigger.get(), buffer_.get(), size_);
    buffer_ = std::move(bigger);
    capacity_ = n;
  }
  return buffer_.get() + size_;
}

void decompress(const std::string& compression, const std::uint8_t* data, std::size_t size, std::uint64_t declared,
                Decompressed& out, const std::string& what) {
  if (compression == "zstd") return decompress_zstd(data, size, declared, out, what);
  if (compression == "lz4") return decompress_lz4(data, size, declared, out, what);
  throw Error(what + ": compression '" + compression + "' is not read (zstd and lz4 are)");
}

std::string compress(const std::string& compression, const std::string& data) {
  std::string out;
  if (compression == "zstd") {
    out.resize(ZSTD_compressBound(data.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), data.data(), data.size(), 1);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
  } else if (compression == "lz4") {
    out.resize(LZ4F_compressFrameBound(data.size(), nullptr));
    const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), data.data(), data.size(), nullptr);
    if (LZ4F_isError(n)) throw Error(std::string("LZ4 compression failed: ") + LZ4F_getErrorName(n));
    out.resize(n);
  } else {
    throw Error("unknown compression '" + compression + "' (none, zstd or lz4)");
  }
  return out;
}

bool is_zstd_frame(const std::uint8_t* data, std::size_t size) {
  return size >= 4 && data[0] == 0x28 && data[1] == 0xB5 && data[2] == 0x2F && data[3] == 0xFD;
}

void decompress_zstd_frame(const std::uint8_t* data, std::size_t size, std::size_t max_size, Decompressed& out,
                           const std::string& what) {
  const unsigned long long n = ZSTD_getFrameContentSize(data, size);
  if (n == ZSTD_CONTENTSIZE_ERROR) throw Error(what + ": corrupt zstd frame (a compressed rosbag2 message)");
  if (n == ZSTD_CONTENTSIZE_UNKNOWN) throw Error(what + ": a zstd frame that does not state its size");
  if (n > max_size) {
    throw Error(what + ": decompresses to " + std::to_string(n) + " bytes, more than the limit of " +
                std::to_string(max_size));
  }
  decompress_zstd(data, size, n, out, what);
}

std::uint32_t crc32_of(const std::uint8_t* data, std::size_t size, std::uint32_t crc) {
  // zlib takes uInt lengths: feed it in pieces.
  while (size > 0) {
    const auto n = static_cast<uInt>(std::min<std::size_t>(size, std::numeric_limits<uInt>::max()));
    crc = static_cast<std::uint32_t>(::crc32(crc, data, n));
    data += n;
    size -= n;
  }
  return crc;
}

}  // namespace tsdf_mcl::rosbag2
