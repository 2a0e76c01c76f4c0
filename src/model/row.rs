//! One row of a kinematic chain: the geometric convention and its numeric fields.
//!
//! A row stores its values in file units (lengths in mm, angles in degrees), so that a robot
//! file written and read again gives the same model to the last bit. Every accessor that feeds
//! computation converts to the internal units (mm, rad).

use crate::geometry::Pose;
use crate::geometry::rotation::{rot_x, rot_y, zyx_to_rotation};
use nalgebra::{Translation3, Vector3};

/// The geometric convention of a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Convention {
    /// Modified DH (Khalil-Kleinfinger), thesis eq. 3.9:
    /// T = RotX(alpha) TransX(a) RotZ(theta) TransZ(d).
    Mdh,
    /// Hayati row for nearly parallel axes, thesis eq. 3.11:
    /// T = RotY(beta) RotX(alpha) TransX(a) RotZ(theta).
    Hayati,
    /// Standard DH, as vendors publish it: T = RotZ(theta) TransZ(d) TransX(a) RotX(alpha).
    Dh,
    /// A general 6-DOF transform for base and tool: T = Trans(x, y, z) Rz(rz) Ry(ry) Rx(rx).
    Transform,
}

impl Convention {
    /// The fields of this convention, in the order of its transform product.
    pub fn fields(self) -> &'static [Field] {
        use Field::*;
        match self {
            Convention::Mdh => &[Alpha, A, Theta, D],
            Convention::Hayati => &[Beta, Alpha, A, Theta],
            Convention::Dh => &[Theta, D, A, Alpha],
            Convention::Transform => &[X, Y, Z, Rz, Ry, Rx],
        }
    }

    /// Lower-case name, as in robot files: `mdh`, `hayati`, `dh`, `transform`.
    pub fn name(self) -> &'static str {
        match self {
            Convention::Mdh => "mdh",
            Convention::Hayati => "hayati",
            Convention::Dh => "dh",
            Convention::Transform => "transform",
        }
    }

    /// The convention of a [`name`](Self::name); None for an unknown name.
    pub fn from_name(s: &str) -> Option<Self> {
        [
            Convention::Mdh,
            Convention::Hayati,
            Convention::Dh,
            Convention::Transform,
        ]
        .into_iter()
        .find(|c| c.name() == s)
    }

    /// The transform as a formula, for documentation in written files.
    pub fn formula(self) -> &'static str {
        match self {
            Convention::Mdh => "T = RotX(alpha) TransX(a) RotZ(theta) TransZ(d)",
            Convention::Hayati => "T = RotY(beta) RotX(alpha) TransX(a) RotZ(theta)",
            Convention::Dh => "T = RotZ(theta) TransZ(d) TransX(a) RotX(alpha)",
            Convention::Transform => "T = Trans(x, y, z) RotZ(rz) RotY(ry) RotX(rx)",
        }
    }
}

/// A numeric field of a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Field {
    /// Link length a: translation along x (mm).
    A,
    /// Link twist alpha: rotation about x (deg in files, rad inside).
    Alpha,
    /// Link offset d: translation along z (mm); a prismatic joint's variable adds to it.
    D,
    /// Joint angle offset theta: rotation about z (deg in files, rad inside); a revolute
    /// joint's variable adds to it.
    Theta,
    /// Hayati twist beta: rotation about y (deg in files, rad inside).
    Beta,
    /// Transform translation along x (mm).
    X,
    /// Transform translation along y (mm).
    Y,
    /// Transform translation along z (mm).
    Z,
    /// Transform rotation about z, first of Z-Y-X (deg in files, rad inside).
    Rz,
    /// Transform rotation about y, second of Z-Y-X (deg in files, rad inside).
    Ry,
    /// Transform rotation about x, third of Z-Y-X (deg in files, rad inside).
    Rx,
    /// A joint's compliance c (mrad per kN m in files, rad per N m inside; um per kN and mm
    /// per N for a prismatic joint): not a row field but a parameter of the joint
    /// ([`super::compliance`]).
    C,
    /// A mass-free compliance coefficient of the joint ([`super::compliance`]): k_jbi for
    /// body `body` (0-based link, or [`PAYLOAD`]) and part `part` (0: mass, mrad per kN m
    /// times kg; 1-3: moment x, y, z, times kg m).
    K {
        /// The body: 0-based link, or [`PAYLOAD`].
        body: u8,
        /// 0: mass; 1, 2, 3: moment along x, y, z of the body's frame.
        part: u8,
    },
}

/// [`Field::K`]'s body number of the payload.
pub const PAYLOAD: u8 = u8::MAX;

impl Field {
    /// Every field, in declaration order.
    pub const ALL: [Field; 12] = [
        Field::A,
        Field::Alpha,
        Field::D,
        Field::Theta,
        Field::Beta,
        Field::X,
        Field::Y,
        Field::Z,
        Field::Rz,
        Field::Ry,
        Field::Rx,
        Field::C,
    ];

    /// Lower-case name, as in robot files and parameter names: `a`, `alpha`, ..., `rx`.
    pub fn name(self) -> &'static str {
        match self {
            Field::A => "a",
            Field::Alpha => "alpha",
            Field::D => "d",
            Field::Theta => "theta",
            Field::Beta => "beta",
            Field::X => "x",
            Field::Y => "y",
            Field::Z => "z",
            Field::Rz => "rz",
            Field::Ry => "ry",
            Field::Rx => "rx",
            Field::C => "c",
            Field::K { .. } => "k",
        }
    }

    /// The field of a [`name`](Self::name); None for an unknown name.
    pub fn from_name(s: &str) -> Option<Self> {
        Field::ALL.into_iter().find(|f| f.name() == s)
    }

    /// True for angles (degrees in files, radians inside), false for lengths (mm).
    pub fn is_angle(self) -> bool {
        matches!(
            self,
            Field::Alpha | Field::Theta | Field::Beta | Field::Rz | Field::Ry | Field::Rx
        )
    }

    /// The unit this field has in files and on the command line (a compliance's is that of
    /// a revolute joint; a prismatic joint's is um per kN).
    pub fn file_unit(self) -> &'static str {
        match self {
            Field::C => "mrad/kNm",
            Field::K { part: 0, .. } => "mrad/kNm*kg",
            Field::K { .. } => "mrad/kNm*kg*m",
            f if f.is_angle() => "deg",
            _ => "mm",
        }
    }

    /// A value converted from internal units (rad, mm, rad per N m) to file units (deg, mm,
    /// mrad per kN m).
    pub fn to_file(self, v: f64) -> f64 {
        match self {
            Field::C | Field::K { .. } => v * super::compliance::FILE_PER_INTERNAL,
            f if f.is_angle() => v.to_degrees(),
            _ => v,
        }
    }

    /// A value converted from file units (deg, mm, mrad per kN m) to internal units (rad, mm,
    /// rad per N m).
    pub fn to_internal(self, v: f64) -> f64 {
        match self {
            Field::C | Field::K { .. } => v / super::compliance::FILE_PER_INTERNAL,
            f if f.is_angle() => v.to_radians(),
            _ => v,
        }
    }
}

/// One row: a convention and its field values in file units (mm, deg).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    convention: Convention,
    /// Values in the order of `convention.fields()`; unused slots stay 0.
    values: [f64; 6],
    /// A 6-DOF transform's rotation before its Z-Y-X angles, T = Trans(x, y, z) R_ref
    /// RotZ(rz) RotY(ry) RotX(rx), while `identify` solves for the frame near its start
    /// ([`Row::rebased`]): there the angles are small turns about the start frame's own
    /// axes, which no gimbal lock touches. Never in a file ([`Row::plain`]).
    reference: Option<nalgebra::Rotation3<f64>>,
}

impl Row {
    /// A row with every field 0.
    pub fn zero(convention: Convention) -> Self {
        Row {
            convention,
            values: [0.0; 6],
            reference: None,
        }
    }

    /// A 6-DOF transform row as the same frame with its rotation taken as the reference and
    /// its angles 0 (other rows as they are): near its start its angles are then turns about
    /// the frame's own z, y and x axes, where at ry = +-90 deg the file's rz and rx turn it
    /// about one axis and no angle turns it about the third (a tool along the flange's x).
    pub(crate) fn rebased(&self) -> Row {
        if self.convention != Convention::Transform {
            return self.clone();
        }
        let mut row = self.clone();
        row.reference = Some(self.rotation());
        for f in [Field::Rz, Field::Ry, Field::Rx] {
            row.set_file_value(f, 0.0);
        }
        row
    }

    /// The row with its reference folded into its angles ([`Row::rebased`] undone: the same
    /// frame, as a file writes it).
    pub(crate) fn plain(&self) -> Row {
        if self.reference.is_none() {
            return self.clone();
        }
        let [rz, ry, rx] = crate::geometry::rotation::rotation_to_zyx(&self.rotation());
        let mut row = self.clone();
        row.reference = None;
        for (f, v) in [(Field::Rz, rz), (Field::Ry, ry), (Field::Rx, rx)] {
            row.set_value(f, v);
        }
        row
    }

    /// Whether the row carries a reference rotation ([`Row::rebased`]).
    pub(crate) fn is_rebased(&self) -> bool {
        self.reference.is_some()
    }

    /// A 6-DOF transform's rotation, R_ref RotZ(rz) RotY(ry) RotX(rx) (identity for others).
    fn rotation(&self) -> nalgebra::Rotation3<f64> {
        let v = |f| self.value(f);
        let angles = zyx_to_rotation(v(Field::Rz), v(Field::Ry), v(Field::Rx));
        match (self.convention, self.reference) {
            (Convention::Transform, Some(r)) => r * angles,
            (Convention::Transform, None) => angles,
            _ => nalgebra::Rotation3::identity(),
        }
    }

    /// The reference rotation before the angles ([`Row::rebased`]), identity without one.
    pub(crate) fn reference(&self) -> nalgebra::Rotation3<f64> {
        self.reference.unwrap_or_else(nalgebra::Rotation3::identity)
    }

    /// A row from `(field, value in mm or deg)` pairs; fields not named stay 0.
    /// Panics if a field does not belong to the convention (a programming error).
    pub fn with(convention: Convention, values: &[(Field, f64)]) -> Self {
        let mut row = Row::zero(convention);
        for &(f, v) in values {
            assert!(
                row.set_file_value(f, v),
                "field {} is not part of a {} row",
                f.name(),
                convention.name()
            );
        }
        row
    }

    /// The row's convention.
    pub fn convention(&self) -> Convention {
        self.convention
    }

    fn slot(&self, f: Field) -> Option<usize> {
        self.convention.fields().iter().position(|&g| g == f)
    }

    /// Value in file units (mm or deg), or None when the convention has no such field.
    pub fn file_value(&self, f: Field) -> Option<f64> {
        self.slot(f).map(|i| self.values[i])
    }

    /// Sets a value in file units; false when the convention has no such field.
    pub fn set_file_value(&mut self, f: Field, v: f64) -> bool {
        match self.slot(f) {
            Some(i) => {
                self.values[i] = v;
                true
            }
            None => false,
        }
    }

    /// Value in internal units (mm or rad); 0 for a field the convention does not have.
    pub fn value(&self, f: Field) -> f64 {
        let v = self.file_value(f).unwrap_or(0.0);
        if f.is_angle() { v.to_radians() } else { v }
    }

    /// Sets a value given in internal units (mm or rad); false when there is no such field.
    /// Angles are stored in degrees, so reading back may differ from `v` by one ulp.
    pub fn set_value(&mut self, f: Field, v: f64) -> bool {
        let file = if f.is_angle() { v.to_degrees() } else { v };
        self.set_file_value(f, file)
    }

    /// The row split as `pre * RotZ(theta) TransZ(d) * post`, with theta (rad) and d (mm) the
    /// row's constant values. A joint adds its variable to theta (revolute) or d (prismatic).
    /// A 6-DOF transform row has theta = d = 0 and everything in `pre`.
    pub fn split(&self) -> Split {
        let v = |f| self.value(f);
        match self.convention {
            Convention::Mdh => Split {
                pre: rot_pose(rot_x(v(Field::Alpha))) * trans_pose(v(Field::A), 0.0, 0.0),
                theta: v(Field::Theta),
                d: v(Field::D),
                post: Pose::identity(),
            },
            Convention::Hayati => Split {
                pre: rot_pose(rot_y(v(Field::Beta)) * rot_x(v(Field::Alpha)))
                    * trans_pose(v(Field::A), 0.0, 0.0),
                theta: v(Field::Theta),
                d: 0.0,
                post: Pose::identity(),
            },
            Convention::Dh => Split {
                pre: Pose::identity(),
                theta: v(Field::Theta),
                d: v(Field::D),
                post: trans_pose(v(Field::A), 0.0, 0.0) * rot_pose(rot_x(v(Field::Alpha))),
            },
            Convention::Transform => Split {
                pre: Pose::from_parts(
                    Translation3::new(v(Field::X), v(Field::Y), v(Field::Z)),
                    self.rotation(),
                ),
                theta: 0.0,
                d: 0.0,
                post: Pose::identity(),
            },
        }
    }

    /// The row's full transform with its constant values (for base and tool rows).
    pub fn transform(&self) -> Pose {
        let s = self.split();
        let mut t = s.pre;
        apply_z(&mut t, s.theta, s.d);
        t * s.post
    }
}

/// A row split around its joint variable; see [`Row::split`].
#[derive(Debug, Clone)]
pub struct Split {
    /// The part of the row before RotZ(theta) TransZ(d) (mm, rad).
    pub pre: Pose,
    /// rad
    pub theta: f64,
    /// mm
    pub d: f64,
    /// The part of the row after RotZ(theta) TransZ(d) (identity except for standard DH).
    pub post: Pose,
}

fn rot_pose(r: nalgebra::Rotation3<f64>) -> Pose {
    Pose::from_parts(Translation3::identity(), r)
}

fn trans_pose(x: f64, y: f64, z: f64) -> Pose {
    Pose::from_parts(Translation3::new(x, y, z), nalgebra::Rotation3::identity())
}

/// `t <- t * RotZ(theta) * TransZ(d)`, in place and without building the factor.
#[inline]
pub fn apply_z(t: &mut Pose, theta: f64, d: f64) {
    // libm's sincos shares one range reduction: a quarter of FK's time saved over sin_cos.
    let (s, c) = libm::sincos(theta);
    apply_z_sc(t, s, c, d);
}

/// [`apply_z`] with sin and cos of theta already known.
#[inline]
pub fn apply_z_sc(t: &mut Pose, s: f64, c: f64, d: f64) {
    let m = t.rotation.matrix_mut_unchecked();
    let x: Vector3<f64> = m.column(0).into();
    let y: Vector3<f64> = m.column(1).into();
    let z: Vector3<f64> = m.column(2).into();
    m.set_column(0, &(x * c + y * s));
    m.set_column(1, &(y * c - x * s));
    t.translation.vector += z * d;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rotation::rot_z;

    fn mat(p: &Pose) -> nalgebra::Matrix4<f64> {
        p.to_homogeneous()
    }

    #[test]
    fn apply_z_equals_explicit_product() {
        let mut t = Pose::from_parts(Translation3::new(1.0, 2.0, 3.0), rot_x(0.4) * rot_y(-1.1));
        let expected = t * rot_pose(rot_z(0.7)) * trans_pose(0.0, 0.0, 5.0);
        apply_z(&mut t, 0.7, 5.0);
        assert!((mat(&t) - mat(&expected)).abs().max() < 1e-14);
    }

    #[test]
    fn each_convention_matches_its_formula() {
        let (a, alpha, d, theta, beta) = (12.0, 30.0, -7.0, 50.0, 4.0);
        let r = |deg: f64| deg.to_radians();
        let tz = |x: f64| trans_pose(0.0, 0.0, x);
        let tx = |x: f64| trans_pose(x, 0.0, 0.0);
        let rx = |deg: f64| rot_pose(rot_x(r(deg)));
        let ry = |deg: f64| rot_pose(rot_y(r(deg)));
        let rz = |deg: f64| rot_pose(rot_z(r(deg)));
        use Field::*;
        let cases = [
            (
                Row::with(
                    Convention::Mdh,
                    &[(A, a), (Alpha, alpha), (D, d), (Theta, theta)],
                ),
                rx(alpha) * tx(a) * rz(theta) * tz(d),
            ),
            (
                Row::with(
                    Convention::Hayati,
                    &[(A, a), (Alpha, alpha), (Beta, beta), (Theta, theta)],
                ),
                ry(beta) * rx(alpha) * tx(a) * rz(theta),
            ),
            (
                Row::with(
                    Convention::Dh,
                    &[(A, a), (Alpha, alpha), (D, d), (Theta, theta)],
                ),
                rz(theta) * tz(d) * tx(a) * rx(alpha),
            ),
            (
                Row::with(
                    Convention::Transform,
                    &[
                        (X, 1.0),
                        (Y, 2.0),
                        (Z, 3.0),
                        (Rz, 10.0),
                        (Ry, 20.0),
                        (Rx, 30.0),
                    ],
                ),
                trans_pose(1.0, 2.0, 3.0) * rz(10.0) * ry(20.0) * rx(30.0),
            ),
        ];
        for (row, expected) in cases {
            let got = row.transform();
            assert!(
                (mat(&got) - mat(&expected)).abs().max() < 1e-12,
                "{:?}",
                row.convention()
            );
        }
    }

    #[test]
    fn values_are_kept_in_file_units() {
        let mut row = Row::zero(Convention::Mdh);
        assert!(row.set_file_value(Field::Alpha, -90.0));
        assert_eq!(row.file_value(Field::Alpha), Some(-90.0));
        assert_eq!(row.value(Field::Alpha), (-90.0f64).to_radians());
        assert!(!row.set_file_value(Field::Beta, 1.0));
        assert_eq!(row.file_value(Field::Beta), None);
        assert_eq!(row.value(Field::Beta), 0.0);
    }
}
