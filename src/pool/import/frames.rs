//! Attitude and vectors from the frames logs use to the one hydrofit uses: body x forward,
//! y starboard, z down (FRD) in a north-east-down world (NED), roll-pitch-yaw in Fossen's
//! zyx convention (Fossen 2011, eq. 2.18). ROS logs use REP-103's FLU body in an ENU world.

use super::log_spec::Frame;
use std::f64::consts::{FRAC_PI_2, PI};

type Mat3 = [[f64; 3]; 3];

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The rotation of a unit quaternion (x, y, z, w) (normalised here).
fn rotation([x, y, z, w]: [f64; 4]) -> Mat3 {
    let n = (x * x + y * y + z * z + w * w).sqrt();
    let (x, y, z, w) = (x / n, y / n, z / n, w / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// Roll, pitch, yaw of a body-to-world rotation (zyx).
fn euler(r: &Mat3) -> [f64; 3] {
    [
        r[2][1].atan2(r[2][2]),
        -r[2][0].clamp(-1.0, 1.0).asin(),
        r[1][0].atan2(r[0][0]),
    ]
}

/// The body-to-world rotation of roll, pitch, yaw (zyx).
pub fn from_euler([phi, theta, psi]: [f64; 3]) -> Mat3 {
    let (sf, cf) = phi.sin_cos();
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = psi.sin_cos();
    [
        [cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st],
        [sp * ct, cp * cf + sf * st * sp, -cp * sf + sp * st * cf],
        [-st, ct * sf, ct * cf],
    ]
}

/// ENU to NED (swap x and y, negate z); FLU to FRD is diag(1, -1, -1).
const NED_ENU: Mat3 = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
const FLU_FRD: Mat3 = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]];

/// Roll, pitch, yaw (NED / FRD) of a quaternion: an FLU body in an ENU world (ROS's
/// convention, the default) or, with `frame: ned`, an FRD body in an NED world.
pub fn euler_from_quaternion(q: [f64; 4], frame: Option<Frame>) -> [f64; 3] {
    let r = rotation(q);
    match frame {
        Some(Frame::Ned | Frame::Frd) => euler(&r),
        _ => euler(&mul(&mul(&NED_ENU, &r), &FLU_FRD)),
    }
}

/// Roll, pitch, yaw given in `frame` as NED / FRD angles: ENU/FLU angles (ROS's rpy) have
/// their pitch negated and their yaw measured from east, counter-clockwise.
pub fn euler_to_ned(e: [f64; 3], frame: Option<Frame>) -> [f64; 3] {
    match frame {
        Some(Frame::Enu | Frame::Flu) => [e[0], -e[1], wrap(FRAC_PI_2 - e[2])],
        _ => e,
    }
}

fn wrap(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    if w == -PI { PI } else { w }
}

/// An ENU vector (x east, y north, z up) in NED.
pub fn enu_to_ned(v: [f64; 3]) -> [f64; 3] {
    [v[1], v[0], -v[2]]
}

/// A world-frame vector (NED, or ENU) in the body frame at attitude `e` (NED / FRD).
pub fn world_to_body(v: [f64; 3], e: [f64; 3], frame: Frame) -> [f64; 3] {
    let ned = match frame {
        Frame::Enu => enu_to_ned(v),
        _ => v,
    };
    let r = from_euler(e);
    std::array::from_fn(|i| (0..3).map(|k| r[k][i] * ned[k]).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn a_ros_quaternion_turns_into_ned_angles() {
        // Level, facing north: in ENU the FLU body's x points along +y, a yaw of +90 deg.
        let q = [0.0, 0.0, (PI / 4.0).sin(), (PI / 4.0).cos()];
        assert!(close(euler_from_quaternion(q, None), [0.0, 0.0, 0.0]));
        // Facing east in ENU (identity): heading 90 deg in NED.
        let e = euler_from_quaternion([0.0, 0.0, 0.0, 1.0], Some(Frame::Enu));
        assert!(close(e, [0.0, 0.0, FRAC_PI_2]), "{e:?}");
        // Nose up 10 deg in FLU (a negative rotation about y) is a positive pitch in FRD.
        let a = -10f64.to_radians() / 2.0;
        let e = euler_from_quaternion([0.0, a.sin(), 0.0, a.cos()], None);
        assert!((e[1] - 10f64.to_radians()).abs() < 1e-12, "{e:?}");
    }

    #[test]
    fn an_ned_quaternion_is_read_as_is() {
        let e = [0.1, -0.2, 0.3];
        let r = from_euler(e);
        // The quaternion of r (Shepperd's method for a rotation this small).
        let w = 0.5 * (1.0 + r[0][0] + r[1][1] + r[2][2]).sqrt();
        let q = [
            (r[2][1] - r[1][2]) / (4.0 * w),
            (r[0][2] - r[2][0]) / (4.0 * w),
            (r[1][0] - r[0][1]) / (4.0 * w),
            w,
        ];
        assert!(close(euler_from_quaternion(q, Some(Frame::Ned)), e));
    }

    #[test]
    fn a_world_velocity_lands_in_the_body() {
        // Heading east, 1 m/s east: all surge.
        let v = world_to_body([0.0, 1.0, 0.0], [0.0, 0.0, FRAC_PI_2], Frame::Ned);
        assert!(close(v, [1.0, 0.0, 0.0]), "{v:?}");
        let v = world_to_body([1.0, 0.0, 0.0], [0.0, 0.0, FRAC_PI_2], Frame::Enu);
        assert!(close(v, [1.0, 0.0, 0.0]), "{v:?}");
        assert!(close(
            euler_to_ned([0.1, 0.2, 0.0], Some(Frame::Enu)),
            [0.1, -0.2, FRAC_PI_2]
        ));
    }
}
