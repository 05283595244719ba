// The .msg definitions of the messages the rosbag2 writer records (ros2/common_interfaces, ros2/rcl_interfaces,
// ros2/geometry2; comments left out), concatenated as the ros2msg schema encoding wants them: MCAP readers such as
// Foxglove's and `ros2 bag` decode a recording's messages from these alone.
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/ros2_messages.hpp"

namespace tsdf_mcl::ros2 {
namespace {

struct Definition {
  const char* text;
  std::vector<const char*> uses;  // the types its fields name, as "package/Type"
};

const std::map<std::string, Definition>& definitions() {
  static const std::map<std::string, Definition> table = {
      {"builtin_interfaces/Time", {"int32 sec\nuint32 nanosec\n", {}}},
      {"std_msgs/Header", {"builtin_interfaces/Time stamp\nstring frame_id\n", {"builtin_interfaces/Time"}}},
      {"sensor_msgs/PointField",
       {"uint8 INT8    = 1\nuint8 UINT8   = 2\nuint8 INT16   = 3\nuint8 UINT16  = 4\nuint8 INT32   = 5\n"
        "uint8 UINT32  = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\n\nstring name\nuint32 offset\nuint8  datatype\n"
        "uint32 count\n",
        {}}},
      {"sensor_msgs/PointCloud2",
       {"std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\nbool    is_bigendian\n"
        "uint32  point_step\nuint32  row_step\nuint8[] data\nbool is_dense\n",
        {"std_msgs/Header", "sensor_msgs/PointField"}}},
      {"geometry_msgs/Vector3", {"float64 x\nfloat64 y\nfloat64 z\n", {}}},
      {"geometry_msgs/Point", {"float64 x\nfloat64 y\nfloat64 z\n", {}}},
      {"geometry_msgs/Quaternion", {"float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n", {}}},
      {"geometry_msgs/Transform",
       {"Vector3 translation\nQuaternion rotation\n", {"geometry_msgs/Vector3", "geometry_msgs/Quaternion"}}},
      {"geometry_msgs/TransformStamped",
       {"std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
        {"std_msgs/Header", "geometry_msgs/Transform"}}},
      {"tf2_msgs/TFMessage", {"geometry_msgs/TransformStamped[] transforms\n", {"geometry_msgs/TransformStamped"}}},
      {"geometry_msgs/Pose",
       {"Point position\nQuaternion orientation\n", {"geometry_msgs/Point", "geometry_msgs/Quaternion"}}},
      {"geometry_msgs/PoseWithCovariance", {"Pose pose\nfloat64[36] covariance\n", {"geometry_msgs/Pose"}}},
      {"geometry_msgs/Twist", {"Vector3  linear\nVector3  angular\n", {"geometry_msgs/Vector3"}}},
      {"geometry_msgs/TwistWithCovariance", {"Twist twist\nfloat64[36] covariance\n", {"geometry_msgs/Twist"}}},
      {"nav_msgs/Odometry",
       {"std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
        "geometry_msgs/TwistWithCovariance twist\n",
        {"std_msgs/Header", "geometry_msgs/PoseWithCovariance", "geometry_msgs/TwistWithCovariance"}}},
      {"geometry_msgs/PoseStamped", {"std_msgs/Header header\nPose pose\n", {"std_msgs/Header", "geometry_msgs/Pose"}}},
      {"geometry_msgs/PoseWithCovarianceStamped",
       {"std_msgs/Header header\nPoseWithCovariance pose\n", {"std_msgs/Header", "geometry_msgs/PoseWithCovariance"}}},
      {"sensor_msgs/Imu",
       {"std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
        "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
        "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n",
        {"std_msgs/Header", "geometry_msgs/Quaternion", "geometry_msgs/Vector3"}}},
  };
  return table;
}

// Appends the definitions `type` uses, depth first, each once.
void append_uses(const std::string& type, std::set<std::string>& done, std::string& out) {
  for (const char* used : definitions().at(type).uses) {
    if (!done.insert(used).second) continue;
    out += std::string(80, '=') + "\nMSG: " + used + "\n" + definitions().at(used).text;
    append_uses(used, done, out);
  }
}

}  // namespace

std::string message_definition(const std::string& type) {
  // "sensor_msgs/msg/PointCloud2" -> "sensor_msgs/PointCloud2", the key above.
  const std::size_t slash = type.find("/msg/");
  const std::string key = slash == std::string::npos ? type : type.substr(0, slash) + type.substr(slash + 4);
  const auto it = definitions().find(key);
  if (slash == std::string::npos || it == definitions().end()) {
    throw Error("no message definition for " + type + " here");
  }
  std::set<std::string> done;
  std::string out = it->second.text;
  append_uses(key, done, out);
  return out;
}

}  // namespace tsdf_mcl::ros2
