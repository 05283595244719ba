// Writes the MCAP test recordings of tests/io/test_rosbag2_foreign.cpp with Foxglove's own MCAP writer (@mcap/core)
// and ROS 2 serializer (@foxglove/rosmsg2-serialization, @foxglove/cdr), not with this project's code: the readers
// are checked on bags written by other tools. Run once where npm works (the files are committed):
//
//   npm install @mcap/core @foxglove/rosmsg @foxglove/rosmsg2-serialization @foxglove/cdr @foxglove/wasm-zstd lz4js
//   node make_foreign_bags.mjs OUT_DIR
//
// Each file holds the same 5 scans (10 points each, frame velodyne, 10 Hz from t = 100 s), /tf odom -> base_link,
// /tf_static base_link -> velodyne, /odom (nav_msgs/Odometry), /ground_truth (geometry_msgs/PoseStamped in map),
// /imu (sensor_msgs/Imu, 20 Hz) and /chatter (std_msgs/String, a type tsdf-mcl does not read). The /tf messages
// are big-endian CDR (CDR_BE), the others little-endian as rmw writes them.
//
//   foreign_zstd.mcap        chunks compressed with zstd, message indexes, summary
//   foreign_lz4.mcap         chunks compressed with lz4 (LZ4 frames), message indexes, summary
//   foreign_no_summary.mcap  chunks uncompressed, no message index, no summary (footer summary_start 0)
import fs from "node:fs";
import path from "node:path";
import { McapWriter } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import { CdrWriter, EncapsulationKind } from "@foxglove/cdr";
import * as zstd from "@foxglove/wasm-zstd";
import lz4js from "lz4js";

const SEP = "=".repeat(80) + "\n";
const HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" + SEP +
  "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";
const VEC = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
const QUAT = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POSE = "MSG: geometry_msgs/Pose\nPoint position\nQuaternion orientation\n" + SEP +
  "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n" + SEP + QUAT;
const DEFS = {
  "sensor_msgs/msg/PointCloud2": "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n" +
    "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n" + SEP + HEADER + SEP +
    "MSG: sensor_msgs/PointField\nuint8 INT8 = 1\nuint8 UINT8 = 2\nuint8 INT16 = 3\nuint8 UINT16 = 4\n" +
    "uint8 INT32 = 5\nuint8 UINT32 = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\nstring name\nuint32 offset\n" +
    "uint8 datatype\nuint32 count\n",
  "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n" + SEP +
    "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\nTransform transform\n" +
    SEP + HEADER + SEP + "MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation\n" + SEP + VEC +
    SEP + QUAT,
  "nav_msgs/msg/Odometry": "std_msgs/Header header\nstring child_frame_id\n" +
    "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n" + SEP + HEADER + SEP +
    "MSG: geometry_msgs/PoseWithCovariance\nPose pose\nfloat64[36] covariance\n" + SEP + POSE + SEP +
    "MSG: geometry_msgs/TwistWithCovariance\nTwist twist\nfloat64[36] covariance\n" + SEP +
    "MSG: geometry_msgs/Twist\nVector3 linear\nVector3 angular\n" + SEP + VEC,
  "geometry_msgs/msg/PoseStamped": "std_msgs/Header header\nPose pose\n" + SEP + HEADER + SEP + POSE,
  "sensor_msgs/msg/Imu": "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n" +
    "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n" +
    "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n" +
    "float64[9] linear_acceleration_covariance\n" + SEP + HEADER + SEP + QUAT + SEP + VEC,
  "std_msgs/msg/String": "string data\n",
};
const QOS = "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n";
const stamp = (t) => ({ sec: Math.floor(t), nanosec: Math.round((t - Math.floor(t)) * 1e9) });
const yawQ = (yaw) => ({ x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) });
const zeros = (n) => new Array(n).fill(0);

// geometry_msgs/TransformStamped[] in big-endian CDR, field by field.
function tfBigEndian(transforms) {
  const w = new CdrWriter({ kind: EncapsulationKind.CDR_BE });
  w.sequenceLength(transforms.length);
  for (const t of transforms) {
    w.int32(t.header.stamp.sec).uint32(t.header.stamp.nanosec).string(t.header.frame_id).string(t.child_frame_id);
    const { translation: p, rotation: q } = t.transform;
    for (const v of [p.x, p.y, p.z, q.x, q.y, q.z, q.w]) w.float64(v);
  }
  return w.data;
}

function cloud(k, t) {
  const data = new Uint8Array(160), view = new DataView(data.buffer);
  for (let i = 0; i < 10; i++) {
    for (const [j, v] of [k + i, i * 0.5, 1.0, i].entries()) view.setFloat32(i * 16 + j * 4, v, true);
  }
  const field = (name, offset) => ({ name, offset, datatype: 7, count: 1 });
  return { header: { stamp: stamp(t), frame_id: "velodyne" }, height: 1, width: 10,
           fields: [field("x", 0), field("y", 4), field("z", 8), field("intensity", 12)],
           is_bigendian: false, point_step: 16, row_step: 160, data, is_dense: true };
}

async function write(file, options) {
  const chunks = [];
  let position = 0n;
  const writable = { position: () => position, write: async (b) => { chunks.push(Buffer.from(b)); position += BigInt(b.length); } };
  const writer = new McapWriter({ writable, chunkSize: 2048, ...options });
  await writer.start({ profile: "ros2", library: "@mcap/core (tsdf-mcl make_foreign_bags.mjs)" });
  const channels = {}, writers = {};
  for (const [topic, type] of [["/tf_static", "tf2_msgs/msg/TFMessage"], ["/points", "sensor_msgs/msg/PointCloud2"],
                               ["/tf", "tf2_msgs/msg/TFMessage"], ["/odom", "nav_msgs/msg/Odometry"],
                               ["/ground_truth", "geometry_msgs/msg/PoseStamped"], ["/imu", "sensor_msgs/msg/Imu"],
                               ["/chatter", "std_msgs/msg/String"]]) {
    const schemaId = await writer.registerSchema({ name: type, encoding: "ros2msg",
                                                   data: new TextEncoder().encode(DEFS[type]) });
    channels[topic] = await writer.registerChannel({ topic, schemaId, messageEncoding: "cdr",
                                                     metadata: new Map([["offered_qos_profiles", QOS]]) });
    writers[topic] = new MessageWriter(parse(DEFS[type], { ros2: true }));
  }
  let sequence = 0;
  const add = async (topic, t, message, bytes) => {
    const ns = BigInt(Math.round(t * 1e9));
    await writer.addMessage({ channelId: channels[topic], sequence: sequence++, logTime: ns, publishTime: ns,
                              data: bytes ?? writers[topic].writeMessage(message) });
  };
  const t0 = 100.0;
  await add("/tf_static", t0, { transforms: [{ header: { stamp: stamp(t0), frame_id: "base_link" },
    child_frame_id: "velodyne", transform: { translation: { x: 0.2, y: 0, z: 0.5 }, rotation: yawQ(0) } }] });
  for (let j = 0; j < 10; j++) {
    const t = t0 + 0.05 * j;
    await add("/imu", t, { header: { stamp: stamp(t), frame_id: "velodyne" }, orientation: { x: 0, y: 0, z: 0, w: 1 },
      orientation_covariance: [-1, ...zeros(8)], angular_velocity: { x: 0, y: 0, z: 0.1 },
      angular_velocity_covariance: zeros(9), linear_acceleration: { x: 0, y: 0, z: 9.81 },
      linear_acceleration_covariance: zeros(9) });
    if (j % 2) continue;
    const k = j / 2;
    const odom = { position: { x: 0.1 * k, y: 0, z: 0 }, orientation: yawQ(0.05 * k) };
    await add("/tf", t, null, tfBigEndian([{ header: { stamp: stamp(t), frame_id: "odom" }, child_frame_id: "base_link",
      transform: { translation: odom.position, rotation: odom.orientation } }]));
    await add("/odom", t, { header: { stamp: stamp(t), frame_id: "odom" }, child_frame_id: "base_link",
      pose: { pose: odom, covariance: zeros(36) },
      twist: { twist: { linear: { x: 1, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.5 } }, covariance: zeros(36) } });
    await add("/ground_truth", t, { header: { stamp: stamp(t), frame_id: "map" },
      pose: { position: { x: 0.1 * k + 1, y: 2, z: 0 }, orientation: yawQ(0.05 * k) } });
    await add("/chatter", t, { data: "scan " + k });
    await add("/points", t, cloud(k, t));
  }
  await writer.end();
  fs.writeFileSync(file, Buffer.concat(chunks));
}

await zstd.isLoaded;
const out = process.argv[2] ?? ".";
await write(path.join(out, "foreign_zstd.mcap"),
            { compressChunk: (d) => ({ compression: "zstd", compressedData: zstd.compress(d, 3) }) });
await write(path.join(out, "foreign_lz4.mcap"),
            { compressChunk: (d) => ({ compression: "lz4", compressedData: lz4js.compress(d) }) });
await write(path.join(out, "foreign_no_summary.mcap"),
            { useStatistics: false, useSummaryOffsets: false, useChunkIndex: false, useMessageIndex: false,
              useAttachmentIndex: false, useMetadataIndex: false, repeatSchemas: false, repeatChannels: false });
