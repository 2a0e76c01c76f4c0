//! Forward kinematics, thesis eq. 3.12-3.13: T = T_R T_1 ... T_N T_T; for a compliant robot
//! at the joints it reaches under gravity, q' = q + delta(q) ([`crate::model::compliance`]).

use super::Pose;
use super::load::{
    Load, accumulate_moments, axis_column, moment_deflection, torque, world_gravity,
};
use crate::model::Robot;
use crate::model::chain::{Motion, apply_motion};

/// The tool pose (mm, in the base row's reference frame) for commanded joints `q` (rad or
/// mm); for a compliant robot, the pose it reaches under gravity.
///
/// Runs through the robot's compiled chain: one constant transform and one RotZ TransZ per
/// joint (a compliant robot: two passes, one for the masses, one for the torques and the
/// deflected chain). Does not allocate. Panics if `q.len()` differs from the robot's joint count.
pub fn tool_pose(robot: &Robot, q: &[f64]) -> Pose {
    let chain = robot.chain();
    assert_eq!(
        q.len(),
        chain.links.len(),
        "joint vector length differs from the robot's DOF"
    );
    if robot.is_compliant() {
        return compliant_tool_pose(robot, q);
    }
    let mut t = chain.head;
    for (i, (link, &qi)) in chain.links.iter().zip(q).enumerate() {
        chain.apply_joint(&mut t, i, qi);
        t *= link.next;
    }
    t
}

/// Joints whose motions [`compliant_tool_pose`] keeps on the stack (later ones are computed
/// again where needed: the same bits).
const CACHED: usize = 8;

/// [`tool_pose`] of a compliant robot without a workspace: the same sums, in the same order,
/// as [`Load`], so both give the same bits. Joint compliances take two passes (the masses'
/// totals, then the torques beside the deflected chain); mass-free coefficients one more
/// walk per joint (the bodies it carries). Each joint's sine and cosine are computed once
/// (for the first [`CACHED`] joints), the deflected joint's from them
/// (`Chain::deflected`); so are the commanded frames and the centres of mass of the first
/// pass, which the second reads again.
fn compliant_tool_pose(robot: &Robot, q: &[f64]) -> Pose {
    let chain = robot.chain();
    let Some(c) = robot.compliance() else {
        unreachable!("a compliant robot has compliances");
    };
    let n = q.len();
    let mut cache = [Motion::default(); CACHED];
    for (i, m) in cache.iter_mut().enumerate().take(n) {
        *m = chain.joint_motion(i, q[i]);
    }
    let motion = |i: usize| {
        if i < CACHED {
            cache[i]
        } else {
            chain.joint_motion(i, q[i])
        }
    };
    let masses = robot.masses();
    let g = world_gravity(robot);
    let (mut mass, mut moment) = (0.0, nalgebra::Vector3::zeros());
    // The first pass's commanded joint frames and centres of mass (world, mm).
    let mut frames = [Pose::identity(); CACHED];
    let mut coms = [nalgebra::Vector3::zeros(); CACHED];
    let mut t = chain.head;
    if let Some(m) = masses {
        for (i, link) in chain.links.iter().enumerate() {
            apply_motion(&mut t, motion(i));
            let b = &m.links[i];
            mass += b.mass_kg;
            let com = t.transform_point(&b.com_mm.into()).coords;
            moment += com * b.mass_kg;
            if i < CACHED {
                frames[i] = t;
                coms[i] = com;
            }
            t *= link.next;
        }
        mass += m.payload.mass_kg;
        moment += t.transform_point(&m.payload.com_mm.into()).coords * m.payload.mass_kg;
    }
    let moments = c.has_moments();
    // Frames the first pass kept are read again: the same operations gave them.
    let kept = |i: usize| masses.is_some() && i < CACHED;
    let (mut rigid, mut loaded) = (chain.head, chain.head);
    for (i, link) in chain.links.iter().enumerate() {
        let commanded = motion(i);
        if kept(i) {
            rigid = frames[i];
        } else {
            apply_motion(&mut rigid, commanded);
        }
        let z = rigid.rotation.matrix().column(2).into();
        let o = rigid.translation.vector;
        let mut dq = 0.0;
        if let Some(m) = masses {
            let tau = torque(!link.prismatic, &z, &o, mass, &moment, &g);
            dq = c.joint(i) * tau;
            let b = &m.links[i];
            mass -= b.mass_kg;
            let com = if kept(i) {
                coms[i]
            } else {
                rigid.transform_point(&b.com_mm.into()).coords
            };
            moment -= com * b.mass_kg;
        }
        if moments {
            // The bodies joint i carries: its own frame on, walked again from it.
            let (mut km, mut ks, mut kh) =
                (0.0, nalgebra::Vector3::zeros(), nalgebra::Vector3::zeros());
            let mut f = rigid;
            accumulate_moments(c, n, i, i, &f, &mut km, &mut ks, &mut kh);
            for b in i + 1..n {
                f *= chain.links[b - 1].next;
                apply_motion(&mut f, motion(b));
                accumulate_moments(c, n, i, b, &f, &mut km, &mut ks, &mut kh);
            }
            // The payload, on the tool frame.
            f *= chain.links[n - 1].next;
            accumulate_moments(c, n, i, n, &f, &mut km, &mut ks, &mut kh);
            dq += moment_deflection(!link.prismatic, &z, &o, km, &ks, &kh, &g);
        }
        apply_motion(&mut loaded, chain.deflected(i, commanded, dq));
        if !kept(i + 1) {
            rigid *= link.next;
        }
        loaded *= link.next;
    }
    loaded
}

/// Every intermediate frame of one configuration; a workspace reused across calls. For a
/// compliant robot these are the frames it reaches under gravity; `load` holds the commanded
/// configuration's frames, torques and deflections.
#[derive(Debug, Clone)]
pub struct Frames {
    /// For joint i, the frame whose z axis is the joint's axis, with its origin on that axis
    /// (world coordinates). For MDH and Hayati rows this is the convention's frame i.
    pub joint: Vec<Pose>,
    /// Frame i of the row's own convention (for standard DH: after TransX(a) RotX(alpha)).
    pub link: Vec<Pose>,
    /// The tool frame.
    pub tool: Pose,
    /// The gravity load and the commanded frames, for a robot with mass properties or
    /// compliances (stale otherwise; `load.compliant` is then false).
    pub load: Load,
}

impl Frames {
    /// A workspace sized for `robot`.
    pub fn new(robot: &Robot) -> Self {
        let n = robot.dof();
        Frames {
            joint: vec![Pose::identity(); n],
            link: vec![Pose::identity(); n],
            tool: Pose::identity(),
            load: Load::new(robot),
        }
    }
}

/// Walks the chain applying joint i's motion `motion_of(i)`, storing every frame.
#[inline]
fn walk_with(
    robot: &Robot,
    joint: &mut [Pose],
    link: &mut [Pose],
    tool: &mut Pose,
    mut motion_of: impl FnMut(usize) -> Motion,
) {
    let chain = robot.chain();
    let mut t = chain.head;
    for (i, l) in chain.links.iter().enumerate() {
        apply_motion(&mut t, motion_of(i));
        joint[i] = t;
        link[i] = t * l.post;
        t *= l.next;
    }
    *tool = t;
}

/// Walks the chain at joints `q`, storing every frame.
#[inline]
fn walk(robot: &Robot, q: &[f64], joint: &mut [Pose], link: &mut [Pose], tool: &mut Pose) {
    let chain = robot.chain();
    walk_with(robot, joint, link, tool, |i| chain.joint_motion(i, q[i]));
}

/// [`walk`] keeping each joint's motion in `motion` (a compliant robot's commanded walk).
#[inline]
fn walk_keeping(
    robot: &Robot,
    q: &[f64],
    motion: &mut [Motion],
    joint: &mut [Pose],
    link: &mut [Pose],
    tool: &mut Pose,
) {
    let chain = robot.chain();
    walk_with(robot, joint, link, tool, |i| {
        motion[i] = chain.joint_motion(i, q[i]);
        motion[i]
    });
}

/// [`walk`] at the commanded motions `motion` deflected by `dq` (rad or mm).
#[inline]
fn walk_deflected(
    robot: &Robot,
    motion: &[Motion],
    dq: &[f64],
    joint: &mut [Pose],
    link: &mut [Pose],
    tool: &mut Pose,
) {
    let chain = robot.chain();
    walk_with(robot, joint, link, tool, |i| {
        chain.deflected(i, motion[i], dq[i])
    });
}

/// Fills `out` with every frame of commanded configuration `q` (rad or mm): for a robot with
/// masses also its gravity load, and for a compliant robot the frames of the joints it
/// reaches. Does not allocate. Panics if `q.len()` or `out` does not fit the robot.
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
    if robot.masses().is_none() && robot.compliance().is_none() {
        // The rigid, massless robot of most calls: one walk, nothing else.
        out.load.compliant = false;
        walk(robot, q, &mut out.joint, &mut out.link, &mut out.tool);
        return;
    }
    let load = &mut out.load;
    walk_keeping(
        robot,
        q,
        &mut load.motion,
        &mut load.joint,
        &mut load.link,
        &mut load.tool,
    );
    load.compute(robot, q);
    if load.compliant {
        walk_deflected(
            robot,
            &load.motion,
            &load.deflection,
            &mut out.joint,
            &mut out.link,
            &mut out.tool,
        );
        for (j, joint) in robot.joints().iter().enumerate() {
            let revolute = joint.joint_type == crate::model::JointType::Revolute;
            out.load.columns[j] = axis_column(&out.joint, &out.tool, revolute, j);
        }
        out.load.fill_maps();
    } else {
        out.joint.copy_from_slice(&load.joint);
        out.link.copy_from_slice(&load.link);
        out.tool = load.tool;
    }
}
