//! Definitions of the message types underwater vehicles commonly log, in ROS 1 and ROS 2
//! flavours, so that a writer can say "a `nav_msgs/Odometry`" without a ROS installation.
//! [`ros1`] and [`ros2`] give a type's full definition text as bags and MCAP files carry it:
//! its own fields, then each type it uses after a line of 80 `=` and `MSG: pkg/Type` (ROS 2:
//! `MSG: pkg/msg/Type`), as `gendeps --cat` and rosbag2's MCAP plugin write them.

use crate::msgdef::{Flavor, short_name, used_types};

/// The types meant for writers (others here are their parts).
pub const COMMON: &[&str] = &[
    "nav_msgs/Odometry",
    "geometry_msgs/TwistStamped",
    "geometry_msgs/PoseStamped",
    "geometry_msgs/WrenchStamped",
    "sensor_msgs/Imu",
    "sensor_msgs/FluidPressure",
    "std_msgs/Float64MultiArray",
    "std_msgs/Float32MultiArray",
    "std_msgs/UInt16MultiArray",
    "std_msgs/Float64",
    "std_msgs/Float32",
    "mavros_msgs/RCOut",
    "mavros_msgs/OverrideRCIn",
];

const VECTOR3: &str = "float64 x\nfloat64 y\nfloat64 z";

/// A multiarray's text: the layout, then `data` of the given array type.
macro_rules! concat_multi {
    ($t:literal) => {
        concat!(
            "# Please look at the MultiArrayLayout message definition for\n",
            "# documentation on all multiarrays.\n\n",
            "MultiArrayLayout  layout        # specification of data layout\n",
            $t,
            "         data          # array of data"
        )
    };
}

/// (type, its own lines) as ROS 1 writes them; ROS 2 has no bare `Header` (see
/// [`own_text`]) and its header's stamp is a `builtin_interfaces/Time` (see [`ROS2_ONLY`]).
const TYPES: &[(&str, &str)] = &[
    ("std_msgs/Header", "uint32 seq\ntime stamp\nstring frame_id"),
    ("geometry_msgs/Point", VECTOR3),
    ("geometry_msgs/Vector3", VECTOR3),
    (
        "geometry_msgs/Quaternion",
        "float64 x\nfloat64 y\nfloat64 z\nfloat64 w",
    ),
    (
        "geometry_msgs/Pose",
        "Point position\nQuaternion orientation",
    ),
    (
        "geometry_msgs/PoseWithCovariance",
        "Pose pose\nfloat64[36] covariance",
    ),
    ("geometry_msgs/Twist", "Vector3  linear\nVector3  angular"),
    (
        "geometry_msgs/TwistWithCovariance",
        "Twist twist\nfloat64[36] covariance",
    ),
    ("geometry_msgs/Wrench", "Vector3  force\nVector3  torque"),
    ("geometry_msgs/TwistStamped", "Header header\nTwist twist"),
    ("geometry_msgs/PoseStamped", "Header header\nPose pose"),
    (
        "geometry_msgs/WrenchStamped",
        "Header header\nWrench wrench",
    ),
    (
        "nav_msgs/Odometry",
        concat!(
            "Header header\nstring child_frame_id\n",
            "geometry_msgs/PoseWithCovariance pose\n",
            "geometry_msgs/TwistWithCovariance twist"
        ),
    ),
    (
        "sensor_msgs/Imu",
        concat!(
            "Header header\n\n",
            "geometry_msgs/Quaternion orientation\n",
            "float64[9] orientation_covariance # Row major about x, y, z axes\n\n",
            "geometry_msgs/Vector3 angular_velocity\n",
            "float64[9] angular_velocity_covariance # Row major about x, y, z axes\n\n",
            "geometry_msgs/Vector3 linear_acceleration\n",
            "float64[9] linear_acceleration_covariance # Row major x, y z"
        ),
    ),
    (
        "sensor_msgs/FluidPressure",
        concat!(
            "Header header\n",
            "float64 fluid_pressure  # Absolute pressure reading in Pascals.\n",
            "float64 variance"
        ),
    ),
    (
        "std_msgs/MultiArrayDimension",
        "string label\nuint32 size\nuint32 stride",
    ),
    (
        "std_msgs/MultiArrayLayout",
        "MultiArrayDimension[] dim\nuint32 data_offset",
    ),
    ("std_msgs/Float64MultiArray", concat_multi!("float64[]")),
    ("std_msgs/Float32MultiArray", concat_multi!("float32[]")),
    ("std_msgs/UInt16MultiArray", concat_multi!("uint16[]")),
    ("std_msgs/Float64", "float64 data"),
    ("std_msgs/Float32", "float32 data"),
    (
        "mavros_msgs/RCOut",
        "std_msgs/Header header\nuint16[] channels",
    ),
    (
        "mavros_msgs/OverrideRCIn",
        "uint16 CHAN_RELEASE=0\nuint16 CHAN_NOCHANGE=65535\n\nuint16[18] channels",
    ),
];

/// The types whose ROS 2 lines differ other than by `Header` -> `std_msgs/Header`.
const ROS2_ONLY: &[(&str, &str)] = &[
    (
        "std_msgs/Header",
        "builtin_interfaces/Time stamp\nstring frame_id",
    ),
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec"),
    ("builtin_interfaces/Duration", "int32 sec\nuint32 nanosec"),
];

/// The ROS 1 `message_definition` of `type_name` (`nav_msgs/Odometry`), if built in.
pub fn ros1(type_name: &str) -> Option<String> {
    full_text(&short_name(type_name), Flavor::Ros1)
}

/// The ROS 2 `ros2msg` schema text of `type_name` (`nav_msgs/msg/Odometry` or
/// `nav_msgs/Odometry`), if built in.
pub fn ros2(type_name: &str) -> Option<String> {
    full_text(&short_name(type_name), Flavor::Ros2)
}

/// The ROS 2 name of a type: `pkg/Type` -> `pkg/msg/Type`.
pub fn ros2_name(type_name: &str) -> String {
    match short_name(type_name).split_once('/') {
        Some((pkg, ty)) => format!("{pkg}/msg/{ty}"),
        None => type_name.to_string(),
    }
}

/// The ROS 2 lines of `type_name` alone (not the types it uses), if built in: the fallback
/// for a type a `.msg` file uses ([`crate::msg_files`]).
pub fn ros2_own(type_name: &str) -> Option<String> {
    own_text(&short_name(type_name), Flavor::Ros2)
}

/// A type's own lines in a flavour (ROS 2 writes a header as `std_msgs/Header header`).
fn own_text(name: &str, flavor: Flavor) -> Option<String> {
    let find = |table: &[(&str, &'static str)]| table.iter().find(|t| t.0 == name).map(|t| t.1);
    if flavor == Flavor::Ros2 {
        if let Some(text) = find(ROS2_ONLY) {
            return Some(text.to_string());
        }
        let lines = find(TYPES)?
            .lines()
            .map(|l| match l.starts_with("Header ") {
                true => format!("std_msgs/{l}"),
                false => l.to_string(),
            });
        return Some(lines.collect::<Vec<_>>().join("\n"));
    }
    find(TYPES).map(str::to_string)
}

fn full_text(name: &str, flavor: Flavor) -> Option<String> {
    let mut text = own_text(name, flavor)?;
    let mut deps = Vec::new();
    collect_deps(name, flavor, &mut deps);
    for dep in deps {
        let shown = if flavor == Flavor::Ros1 {
            dep.clone()
        } else {
            ros2_name(&dep)
        };
        text.push_str(&format!("\n{}\nMSG: {shown}\n", "=".repeat(80)));
        text.push_str(&own_text(&dep, flavor).expect("every dependency is in TYPES"));
    }
    Some(text)
}

/// The types `name` uses, depth first in order of first use (as `gendeps` lists them).
fn collect_deps(name: &str, flavor: Flavor, out: &mut Vec<String>) {
    let text = own_text(name, flavor).expect("collect_deps is called with known types");
    let pkg = name.split_once('/').map_or("", |p| p.0);
    for used in used_types(&text, flavor).expect("built-in definitions parse") {
        let full = match used.as_str() {
            "Header" => "std_msgs/Header".to_string(),
            t if t.contains('/') => short_name(t),
            t => format!("{pkg}/{t}"),
        };
        if !out.contains(&full) {
            out.push(full.clone());
            collect_deps(&full, flavor, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgdef::{Definition, schema};

    #[test]
    fn every_common_type_parses_in_both_flavours() {
        for t in COMMON {
            let s1 = schema(&ros1(t).unwrap(), t, Flavor::Ros1).unwrap();
            let s2 = schema(&ros2(t).unwrap(), &ros2_name(t), Flavor::Ros2).unwrap();
            assert_eq!(s1.has_header(), s2.has_header(), "{t}");
            assert!(!s1.fields.is_empty() && !s2.fields.is_empty(), "{t}");
        }
        let odom = ros2("nav_msgs/msg/Odometry").unwrap();
        assert!(odom.contains("MSG: geometry_msgs/msg/Twist\n"), "{odom}");
        assert!(
            odom.contains("MSG: builtin_interfaces/msg/Time\n"),
            "{odom}"
        );
    }

    /// The MD5 sums ROS 1 (genmsg) gives these types; also what `rosbags` computes.
    #[test]
    fn ros1_md5_sums_are_the_real_ones() {
        let known = [
            ("std_msgs/Header", "2176decaecbce78abc3b96ef049fabed"),
            ("nav_msgs/Odometry", "cd5e73d190d741a2f92e81eda573aca7"),
            (
                "geometry_msgs/TwistStamped",
                "98d34b0043a2093cf9d9345ab6eef12e",
            ),
            (
                "geometry_msgs/WrenchStamped",
                "d78d3cb249ce23087ade7e7d0c40cfa7",
            ),
            (
                "geometry_msgs/PoseStamped",
                "d3812c3cbc69362b77dc0b19b345f8f5",
            ),
            ("sensor_msgs/Imu", "6a62c6daae103f4ff57a132d6f95cec2"),
            (
                "sensor_msgs/FluidPressure",
                "804dc5cea1c5306d6a2eb80b9833befe",
            ),
            (
                "std_msgs/Float64MultiArray",
                "4b7d974086d4060e7db4613a7e6c3ba4",
            ),
            (
                "std_msgs/Float32MultiArray",
                "6a40e0ffa6a17a503ac3f8616991b1f6",
            ),
            (
                "std_msgs/UInt16MultiArray",
                "52f264f1c973c4b73790d384c6cb4484",
            ),
        ];
        for (t, md5) in known {
            let d = Definition::parse(&ros1(t).unwrap(), t, Flavor::Ros1).unwrap();
            assert_eq!(d.md5().unwrap(), md5, "{t}");
        }
    }
}
