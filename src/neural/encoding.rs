//! What the network sees of a configuration: its input features and their derivatives by
//! the joints.

use crate::kinematics::{Frames, frames};
use crate::model::{JointType, Robot};
use nalgebra::Vector3;

/// How joints become network inputs (then standardised to mean 0, deviation 1, each
/// deviation at least its floor: [`Encoding::scale_floors`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Encoding {
    /// sin q and cos q of each revolute joint (the value of prismatic ones): periodic, so
    /// q and q + 2 pi look alike, as gear errors of one revolution do.
    SinCos,
    /// The joint values themselves (rad, mm).
    Angles,
    /// sin q and cos q as `SinCos`, then the direction of gravity (the robot base's -z)
    /// in each link frame of the model: what loads each joint and link, whatever the
    /// robot's structure (for parallel axes it carries the sums q2 + q3, q2 + q3 + q4).
    Gravity,
}

impl Encoding {
    /// Every encoding.
    pub const ALL: [Encoding; 3] = [Encoding::SinCos, Encoding::Angles, Encoding::Gravity];

    /// Lower-case name, as in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Encoding::SinCos => "sincos",
            Encoding::Angles => "angles",
            Encoding::Gravity => "gravity",
        }
    }

    /// Number of features of a robot's configuration.
    pub fn len(self, robot: &Robot) -> usize {
        let joints: usize = robot
            .joints()
            .iter()
            .map(|j| self.per_joint(j.joint_type))
            .sum();
        match self {
            Encoding::Gravity => joints + 3 * robot.dof(),
            _ => joints,
        }
    }

    /// Whether the features see a joint of type `t` only modulo whole turns (q and q + 2 pi
    /// give the same inputs): a revolute joint under `SinCos` or `Gravity`.
    pub fn is_periodic(self, t: JointType) -> bool {
        t == JointType::Revolute && self != Encoding::Angles
    }

    fn per_joint(self, t: JointType) -> usize {
        match (self, t) {
            (Encoding::SinCos | Encoding::Gravity, JointType::Revolute) => 2,
            _ => 1,
        }
    }

    /// The least deviation each feature is standardised by ([`SCALE_FLOOR`] for a sine, a
    /// cosine, a gravity component or a revolute joint's angle in rad; [`SCALE_FLOOR_MM`]
    /// for a prismatic joint's value in mm), in the order of [`Encoding::features`].
    pub fn scale_floors(self, robot: &Robot) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.len(robot));
        for j in robot.joints() {
            let floor = match j.joint_type {
                JointType::Revolute => SCALE_FLOOR,
                _ => SCALE_FLOOR_MM,
            };
            out.extend(std::iter::repeat_n(floor, self.per_joint(j.joint_type)));
        }
        if self == Encoding::Gravity {
            out.extend(std::iter::repeat_n(SCALE_FLOOR, 3 * robot.dof()));
        }
        out
    }

    /// The raw features of `q` (rad, mm) into `out` (cleared first); `ws` is an FK workspace
    /// of `robot` (used by `Gravity`).
    pub fn features(self, robot: &Robot, q: &[f64], ws: &mut Frames, out: &mut Vec<f64>) {
        out.clear();
        for (j, v) in robot.joints().iter().zip(q) {
            match (self, j.joint_type) {
                (Encoding::SinCos | Encoding::Gravity, JointType::Revolute) => {
                    let (s, c) = libm::sincos(*v);
                    out.push(s);
                    out.push(c);
                }
                _ => out.push(*v),
            }
        }
        if self == Encoding::Gravity {
            frames(robot, q, ws);
            let g = gravity(robot);
            for link in &ws.link {
                out.extend((link.rotation.inverse() * g).iter());
            }
        }
    }

    /// Calls `f(joint, feature, d feature / d q_joint)` for every non-zero derivative of the
    /// raw features at `q`; `ws` as for [`Encoding::features`].
    pub fn for_each_derivative(
        self,
        robot: &Robot,
        q: &[f64],
        ws: &mut Frames,
        mut f: impl FnMut(usize, usize, f64),
    ) {
        let mut col = 0;
        for (j, joint) in robot.joints().iter().enumerate() {
            match (self, joint.joint_type) {
                (Encoding::SinCos | Encoding::Gravity, JointType::Revolute) => {
                    let (s, c) = libm::sincos(q[j]);
                    f(j, col, c);
                    f(j, col + 1, -s);
                }
                _ => f(j, col, 1.0),
            }
            col += self.per_joint(joint.joint_type);
        }
        if self == Encoding::Gravity {
            // Joint j <= i turns link frame i about its world axis a_j:
            // d(R_i^T g)/dq_j = -R_i^T (a_j x g).
            frames(robot, q, ws);
            let g = gravity(robot);
            for i in 0..robot.dof() {
                let inv = ws.link[i].rotation.inverse();
                for j in 0..=i {
                    if robot.joints()[j].joint_type != JointType::Revolute {
                        continue;
                    }
                    let a: Vector3<f64> = ws.joint[j].rotation.matrix().column(2).into();
                    let d = -(inv * a.cross(&g));
                    for r in 0..3 {
                        f(j, col + 3 * i + r, d[r]);
                    }
                }
            }
        }
    }
}

/// The least deviation (a unit vector's component, a sine or cosine, or rad) a revolute
/// joint's features are standardised by: what a turn of about 3 deg moves them. A feature
/// the training rows hold nearly still carries what the data do not vary, and standardised
/// to deviation 1 a step off their manifold becomes many deviations: on Series B the
/// flange's x axis stays level within 0.04 deg (gravity's x in the flange frame varies by
/// 7.7e-4), so 1 deg of q6 moved that input by 11 deviations, the RBF network's output fell
/// by half, and the training domain put the configuration outside (its correction faded to
/// nothing 0.4 deg away). Traces of a calibration's axis tilts (gravity along a tilted
/// parallel axis, 1e-4) were inflated the same way.
pub const SCALE_FLOOR: f64 = 0.05;

/// The least deviation (mm) a prismatic joint's value is standardised by.
pub const SCALE_FLOOR_MM: f64 = 1.0;

/// The direction of gravity in the world frame: -z of the robot's base row.
fn gravity(robot: &Robot) -> Vector3<f64> {
    -robot
        .base()
        .transform()
        .rotation
        .matrix()
        .column(2)
        .into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::read_robot;

    #[test]
    fn every_feature_has_its_scale_floor() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let robot = read_robot(root.join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
        for e in Encoding::ALL {
            let floors = e.scale_floors(&robot);
            assert_eq!(floors.len(), e.len(&robot), "{e:?}");
            assert!(floors.iter().all(|&f| f == SCALE_FLOOR), "{e:?}");
        }
        // A prismatic joint's value (mm) has its own floor, in its place among the joints.
        let frame =
            "convention = \"transform\"\nx = 0.0\ny = 0.0\nz = 0.0\nrz = 0.0\nry = 0.0\nrx = 0.0\n";
        let joint = |kind: &str, lim: (f64, f64)| {
            format!(
                "\n[[joint]]\nconvention = \"dh\"\ntype = \"{kind}\"\nd = 100.0\na = 300.0\n\
                 alpha = 0.0\nlimits = [{:?}, {:?}]\n",
                lim.0, lim.1
            )
        };
        let text = format!(
            "name = \"rpr\"\n[base]\n{frame}{}{}{}\n[tool]\n{frame}",
            joint("revolute", (-90.0, 90.0)),
            joint("prismatic", (0.0, 200.0)),
            joint("revolute", (-90.0, 90.0))
        );
        let rpr = crate::model::file::parse_robot(&text, std::path::Path::new("rpr.toml")).unwrap();
        let mm = SCALE_FLOOR_MM;
        let f = SCALE_FLOOR;
        assert_eq!(Encoding::Angles.scale_floors(&rpr), vec![f, mm, f]);
        assert_eq!(Encoding::SinCos.scale_floors(&rpr), vec![f, f, mm, f, f]);
        let g = Encoding::Gravity.scale_floors(&rpr);
        assert_eq!(g[..5], [f, f, mm, f, f]);
        assert_eq!(g.len(), 5 + 9);
        assert!(g[5..].iter().all(|&v| v == f));
        // A feature that varies less than its floor is scaled by the floor; one that varies
        // more keeps its deviation; a constant one keeps 1.
        let rows = [vec![0.0, 1e-3, 5.0], vec![1.0, -1e-3, 5.0]];
        let a = crate::neural::weights::Affine::standardise(&rows).floored(&[0.05; 3]);
        assert_eq!(a.scale, vec![0.5, 0.05, 1.0]);
    }

    #[test]
    fn derivatives_match_central_differences() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let robot = read_robot(root.join("datasets/robots/ur10.toml")).unwrap();
        let q = [0.3, -1.2, 2.0, -0.4, 1.1, -2.9];
        let mut ws = Frames::new(&robot);
        for enc in Encoding::ALL {
            let n = enc.len(&robot);
            let mut d = vec![vec![0.0; n]; 6];
            enc.for_each_derivative(&robot, &q, &mut ws, |j, k, v| d[j][k] += v);
            let (mut fp, mut fm) = (Vec::new(), Vec::new());
            for j in 0..6 {
                let (mut qp, mut qm) = (q, q);
                qp[j] += 1e-6;
                qm[j] -= 1e-6;
                enc.features(&robot, &qp, &mut ws, &mut fp);
                enc.features(&robot, &qm, &mut ws, &mut fm);
                assert_eq!(fp.len(), n);
                for k in 0..n {
                    let fd = (fp[k] - fm[k]) / 2e-6;
                    assert!((fd - d[j][k]).abs() < 1e-8, "{enc:?} {j} {k}");
                }
            }
        }
    }
}
