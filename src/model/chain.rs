//! A robot's chain compiled into constant transforms (thesis eq. 3.12: T = T_R T_1 ... T_N
//! T_T, each joint's row split around its RotZ TransZ): what forward kinematics runs
//! through, and one joint's motion.

use super::axes::{Anchor, ParamAxis};
use super::joint::{Joint, JointType};
use super::row::{Row, apply_z, apply_z_sc};
use crate::geometry::Pose;

/// Constant parts of one joint in the compiled chain.
#[derive(Debug, Clone)]
pub(crate) struct Link {
    /// Constant theta (rad) and d (mm) of the row; the joint variable adds to one of them.
    pub theta: f64,
    pub d: f64,
    pub prismatic: bool,
    /// The part of the row after its RotZ TransZ (identity except for standard DH).
    pub post: Pose,
    /// Everything from this joint's RotZ TransZ to the next joint's RotZ TransZ:
    /// `post_i * pre_{i+1}`, or `post_N * T_tool` for the last joint.
    pub next: Pose,
}

/// The chain compiled into constant transforms.
#[derive(Debug, Clone)]
pub(crate) struct Chain {
    /// `T_base * pre_1`.
    pub head: Pose,
    pub links: Vec<Link>,
    /// The base row's transform.
    pub base: Pose,
    /// The screw of every parameter, in the order of
    /// [`Robot::parameters`](super::Robot::parameters).
    pub axes: Vec<ParamAxis>,
}

/// The chain of `base`, `joints` and `tool` compiled into constant transforms, with every
/// parameter's screw.
pub(super) fn compile(base: &Row, joints: &[Joint], tool: &Row) -> Chain {
    let splits: Vec<_> = joints.iter().map(|j| j.row.split()).collect();
    let base_t = base.transform();
    let head = base_t * splits[0].pre;
    let mut axes = super::axes::row_axes(base, None, Anchor::World);
    for (i, j) in joints.iter().enumerate() {
        axes.extend(super::axes::row_axes(&j.row, Some(i), Anchor::Entry(i)));
    }
    axes.extend(super::axes::row_axes(tool, None, Anchor::ToolEntry));
    let tool_t = tool.transform();
    let links = joints
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let s = &splits[i];
            let next = match splits.get(i + 1) {
                Some(n) => s.post * n.pre,
                None => s.post * tool_t,
            };
            Link {
                theta: s.theta,
                d: s.d,
                prismatic: j.joint_type == JointType::Prismatic,
                post: s.post,
                next,
            }
        })
        .collect();
    Chain {
        head,
        links,
        base: base_t,
        axes,
    }
}

impl Chain {
    /// Applies joint i's variable part to `t`: `t <- t * RotZ(theta) TransZ(d)`.
    #[inline]
    pub(crate) fn apply_joint(&self, t: &mut Pose, i: usize, q: f64) {
        let l = &self.links[i];
        if l.prismatic {
            apply_z(t, l.theta, l.d + q);
        } else {
            apply_z(t, l.theta + q, l.d);
        }
    }

    /// Joint i's RotZ TransZ at its value q (rad or mm) as the sine and cosine of its angle
    /// and its offset (mm): what [`Chain::apply_joint`] applies, for [`apply_motion`].
    #[inline]
    pub(crate) fn joint_motion(&self, i: usize, q: f64) -> Motion {
        let l = &self.links[i];
        let (theta, d) = if l.prismatic {
            (l.theta, l.d + q)
        } else {
            (l.theta + q, l.d)
        };
        let (sin, cos) = libm::sincos(theta);
        Motion { sin, cos, d }
    }

    /// Joint i's motion `m` moved on by `dq` (rad or mm; a deflection): the angle by the
    /// angle-addition formulas from the sine and cosine of dq alone, which, small, needs no
    /// range reduction, so a deflected joint costs no second full sincos. `m` itself when dq
    /// is zero.
    #[inline]
    pub(crate) fn deflected(&self, i: usize, m: Motion, dq: f64) -> Motion {
        if dq == 0.0 {
            return m;
        }
        if self.links[i].prismatic {
            return Motion { d: m.d + dq, ..m };
        }
        let (sd, cd) = libm::sincos(dq);
        Motion {
            sin: m.sin * cd + m.cos * sd,
            cos: m.cos * cd - m.sin * sd,
            d: m.d,
        }
    }
}

/// One joint's RotZ(theta) TransZ(d): sin and cos of theta, and d (mm).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Motion {
    pub sin: f64,
    pub cos: f64,
    pub d: f64,
}

/// `t <- t * RotZ(theta) TransZ(d)` for the motion `m`.
#[inline]
pub(crate) fn apply_motion(t: &mut Pose, m: Motion) {
    apply_z_sc(t, m.sin, m.cos, m.d);
}
