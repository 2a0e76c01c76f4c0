//! Forward kinematics, thesis eq. 3.12-3.13: T = T_R T_1 ... T_N T_T.

use super::Pose;
use crate::model::Robot;

/// The tool pose (mm, in the base row's reference frame) for joints `q` (rad or mm).
///
/// Runs through the robot's compiled chain: one constant transform and one RotZ TransZ per
/// joint. Does not allocate. Panics if `q.len()` differs from the robot's joint count.
pub fn tool_pose(robot: &Robot, q: &[f64]) -> Pose {
    let chain = robot.chain();
    assert_eq!(
        q.len(),
        chain.links.len(),
        "joint vector length differs from the robot's DOF"
    );
    let mut t = chain.head;
    for (i, (link, &qi)) in chain.links.iter().zip(q).enumerate() {
        chain.apply_joint(&mut t, i, qi);
        t *= link.next;
    }
    t
}

/// Every intermediate frame of one configuration; a workspace reused across calls.
#[derive(Debug, Clone)]
pub struct Frames {
    /// For joint i, the frame whose z axis is the joint's axis, with its origin on that axis
    /// (world coordinates). For MDH and Hayati rows this is the convention's frame i.
    pub joint: Vec<Pose>,
    /// Frame i of the row's own convention (for standard DH: after TransX(a) RotX(alpha)).
    pub link: Vec<Pose>,
    /// The tool frame.
    pub tool: Pose,
}

impl Frames {
    /// A workspace sized for `robot`.
    pub fn new(robot: &Robot) -> Self {
        let n = robot.dof();
        Frames {
            joint: vec![Pose::identity(); n],
            link: vec![Pose::identity(); n],
            tool: Pose::identity(),
        }
    }
}

/// Fills `out` with every frame of configuration `q` (rad or mm). Does not allocate.
/// Panics if `q.len()` or `out` does not fit the robot.
pub fn frames(robot: &Robot, q: &[f64], out: &mut Frames) {
    let chain = robot.chain();
    assert_eq!(
        q.len(),
        chain.links.len(),
        "joint vector length differs from the robot's DOF"
    );
    assert_eq!(
        out.joint.len(),
        chain.links.len(),
        "workspace made for another robot"
    );
    let mut t = chain.head;
    for (i, link) in chain.links.iter().enumerate() {
        chain.apply_joint(&mut t, i, q[i]);
        out.joint[i] = t;
        out.link[i] = t * link.post;
        t *= link.next;
    }
    out.tool = t;
}
