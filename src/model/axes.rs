//! Each parameter of a row as an elementary motion (a screw) fixed in a frame of the chain;
//! the identification Jacobian is built from these (thesis eq. 4.19-4.21).

use super::row::{Convention, Field, Row};
use crate::geometry::rotation::{rot_y, rot_z};
use nalgebra::Vector3;

/// Which frame of a configuration a parameter's screw is fixed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Anchor {
    /// The world frame (base row).
    World,
    /// The frame before joint i's row (the base frame, or link frame i-1).
    Entry(usize),
    /// Joint i's frame after its RotZ TransZ.
    Joint(usize),
    /// The frame before the tool row (link frame N).
    ToolEntry,
}

/// A parameter as an elementary motion: rotation about the line through `c` along `u`, or
/// translation along `u`, both in the anchor frame's coordinates. Changing the parameter by
/// dp moves every frame after it by that motion times dp.
#[derive(Debug, Clone)]
pub(crate) struct ParamAxis {
    pub anchor: Anchor,
    pub rotation: bool,
    pub u: nalgebra::Vector3<f64>,
    pub c: nalgebra::Vector3<f64>,
}

/// The screws of a row's parameters, in the order of `row.convention().fields()`.
///
/// `joint` is the joint index for joint rows (None for base and tool rows, whose parts after
/// the RotZ TransZ are constant and so expressed in the entry frame too); `entry` is the frame
/// before the row.
pub(crate) fn row_axes(row: &Row, joint: Option<usize>, entry: Anchor) -> Vec<ParamAxis> {
    let x = Vector3::x();
    let y = Vector3::y();
    let z = Vector3::z();
    let zero = Vector3::zeros();
    let v = |f| row.value(f);
    let s = row.split();
    let rot = |anchor, u, c| ParamAxis {
        anchor,
        rotation: true,
        u,
        c,
    };
    let trans = |anchor, u| ParamAxis {
        anchor,
        rotation: false,
        u,
        c: zero,
    };
    // Screws after the row's RotZ TransZ: in the joint frame for joints; for fixed rows,
    // carried into the entry frame through the constant pre * RotZ(theta) TransZ(d).
    let after = |u: Vector3<f64>, c: Vector3<f64>, rotation: bool| match joint {
        Some(i) => ParamAxis {
            anchor: Anchor::Joint(i),
            rotation,
            u,
            c,
        },
        None => {
            let mut m = s.pre;
            super::row::apply_z(&mut m, s.theta, s.d);
            ParamAxis {
                anchor: entry,
                rotation,
                u: m.rotation * u,
                c: m * nalgebra::Point3::from(c) - nalgebra::Point3::origin(),
            }
        }
    };
    let z_axis = s.pre.rotation * z;
    let z_point = s.pre.translation.vector;
    row.convention()
        .fields()
        .iter()
        .map(|&f| match (row.convention(), f) {
            (Convention::Mdh, Field::Alpha) => rot(entry, x, zero),
            (Convention::Mdh, Field::A) => trans(entry, x),
            (Convention::Hayati, Field::Beta) => rot(entry, y, zero),
            (Convention::Hayati, Field::Alpha) => rot(entry, rot_y(v(Field::Beta)) * x, zero),
            (Convention::Hayati, Field::A) => trans(entry, rot_y(v(Field::Beta)) * x),
            (Convention::Mdh | Convention::Hayati | Convention::Dh, Field::Theta) => {
                rot(entry, z_axis, z_point)
            }
            (Convention::Mdh | Convention::Dh, Field::D) => trans(entry, z_axis),
            (Convention::Dh, Field::A) => after(x, zero, false),
            (Convention::Dh, Field::Alpha) => after(x, Vector3::new(v(Field::A), 0.0, 0.0), true),
            (Convention::Transform, Field::X) => trans(entry, x),
            (Convention::Transform, Field::Y) => trans(entry, y),
            (Convention::Transform, Field::Z) => trans(entry, z),
            (Convention::Transform, f) => {
                let t = Vector3::new(v(Field::X), v(Field::Y), v(Field::Z));
                let u = match f {
                    Field::Rz => z,
                    Field::Ry => rot_z(v(Field::Rz)) * y,
                    _ => rot_z(v(Field::Rz)) * rot_y(v(Field::Ry)) * x,
                };
                rot(entry, row.reference() * u, t)
            }
            (c, f) => unreachable!("{} has no field {}", c.name(), f.name()),
        })
        .collect()
}
