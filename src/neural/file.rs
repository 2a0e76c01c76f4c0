//! The compensator file (JSON, version 8): format and version, form, encoding, shapes,
//! normalisations, training domain, the robot file it runs in series with (embedded, with its
//! hash), one burn record (burnpack bytes, hex) per MLP of the ensemble, the RBF network
//! (`rbf`: centres, one kernel per output with its widths and variances, weights; or null),
//! the MLPs' share of the correction where both are present (`mlp_share`), the shrinkage of
//! the MLPs' mean (`shrink`: centre and signal variance, or null), whether training refined
//! the embedded model (`model_refined`), and a checksum of it all.
//!
//! Version 8 records whether training refined the embedded model; earlier files are read as
//! unknown: not refined for the domain (a compensator without a network then flags no
//! configuration, as it did), and not known unrefined where a robot file's tool or payload
//! would be taken over (`predict`, `evaluate` and `compensate` keep the file's own then).
//!
//! Version 7 gave each RBF kernel its covariance function (`covariance`: `matern52`, the
//! default since, or `squared_exponential`); earlier files are read with the squared
//! exponential they were made with.
//! Version 6 added the MLPs' share; earlier files are read with the equal say (1/2) they
//! were made with.
//! Version 5 gave the RBF network one kernel per output; version 3 and 4 files, whose outputs
//! shared one kernel (`widths`, `signal_variance`, `noise_variance` beside the weights), are
//! read as one kernel serving every output. Version 4 added the shrinkage; version 3 files are
//! read without it (as they were made).
//! Version 3 added the RBF network; version 2 files (MLPs only) are read as before. Version 2
//! changed the inputs (encodings, standardisation), the pose form's frame (the robot's base
//! frame) and added ensembles and the domain: version 1 files are refused with a message that
//! says so.

use super::compensator::{Compensator, Form};
use super::domain::Domain;
use super::encoding::Encoding;
use super::net::{record_bytes, weights_from_record};
use super::rbf::{Rbf, SharedKernelRbf};
use super::settings::{MIX_SHARE, check_share};
use super::shrink::Shrink;
use super::weights::{Affine, VALUE_BOUND};
use crate::error::{Error, IN_MEMORY, Location, Result};
use crate::model::{Robot, robot_to_toml};
use serde_json::Value;
use std::path::Path;

const FORMAT: &str = "robocal-compensator";
const VERSION: u64 = 8;
/// The oldest version this robocal reads.
const OLDEST: u64 = 2;

impl Compensator {
    /// The compensator file's text.
    pub fn to_file_text(&self) -> Result<String> {
        // The bounds the reader checks: a file is never written that cannot be read back.
        let finite = self
            .members
            .iter()
            .all(|w| w.to_vector().iter().all(|v| v.abs() <= VALUE_BOUND))
            && self.input_norm.is_valid()
            && self.output_norm.is_valid()
            && self.domain.is_valid(self.robot.dof(), self.inputs())
            && self
                .rbf
                .as_ref()
                .is_none_or(|r| r.is_valid(self.inputs(), self.outputs()))
            && self
                .shrink
                .as_ref()
                .is_none_or(|s| s.is_valid(self.outputs(), self.members.len()))
            && check_share(self.mlp_share).is_ok();
        if !finite {
            return Err(Error::Invalid(
                "the compensator holds a non-finite or out-of-bounds weight, normalisation, \
                 domain value or MLP share; nothing was written"
                    .into(),
            ));
        }
        let robot_toml = robot_to_toml(&self.robot);
        let records = self
            .members
            .iter()
            .map(|w| record_bytes(w).map(|b| hex(&b)))
            .collect::<Result<Vec<_>>>()?;
        let mut body = serde_json::json!({
            "format": FORMAT,
            "version": VERSION,
            "form": self.form,
            "encoding": self.encoding,
            "inputs": self.inputs(),
            "hidden": self.hidden(),
            "outputs": self.outputs(),
            "input_norm": self.input_norm,
            "output_norm": self.output_norm,
            "domain": self.domain,
            "robot_toml": robot_toml,
            "robot_hash": format!("{:016x}", fnv1a(robot_toml.as_bytes())),
            "network_records_burnpack_hex": records,
            "rbf": self.rbf,
            "mlp_share": self.mlp_share,
            "shrink": self.shrink,
            // Unknown (a version 7 file's) is written as it was read: not refined.
            "model_refined": self.model_refined.unwrap_or(false),
        });
        let sum = fnv1a(
            serde_json::to_string(&body)
                .map_err(|e| Error::Invalid(e.to_string()))?
                .as_bytes(),
        );
        body["checksum"] = serde_json::json!(format!("{sum:016x}"));
        serde_json::to_string_pretty(&body).map_err(|e| Error::Invalid(e.to_string()))
    }

    /// Writes the compensator file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, self.to_file_text()?.as_bytes())
    }

    /// Reads a compensator file; a wrong format, version, checksum, robot hash, record, shape
    /// or a non-finite number is an error naming the file.
    pub fn load(path: &Path) -> Result<Compensator> {
        let text = crate::io::read_text(path)?;
        Self::from_file_text(&text, path)
    }

    /// Reads a compensator file to run with `robot`'s joints: a compensator trained for other
    /// joints (number or type), or whose model is another arm than `robot`
    /// ([`crate::kinematics::another_arm`]: the distances between flange positions differ by
    /// more than a tenth of the arm), is an error naming the file.
    pub fn load_for(path: &Path, robot: &Robot) -> Result<Compensator> {
        let c = Self::load(path)?;
        if !c.robot.same_joints(robot) {
            // R revolute, P prismatic, joint by joint.
            let kinds = |r: &Robot| -> String {
                r.joints()
                    .iter()
                    .map(|j| match j.joint_type {
                        crate::model::JointType::Revolute => 'R',
                        crate::model::JointType::Prismatic => 'P',
                    })
                    .collect()
            };
            return Err(Error::input(
                Location::file(path),
                format!(
                    "the compensator was trained for a robot with other joints ({}) than the \
                     robot given ({})",
                    kinds(&c.robot),
                    kinds(robot)
                ),
            ));
        }
        if let Some(gap) = crate::kinematics::another_arm(robot, &c.robot) {
            return Err(Error::input(
                Location::file(path),
                format!(
                    "the compensator was trained for another robot than the robot given (or \
                     the robot file is another robot's): between its model and the robot \
                     given, {gap}"
                ),
            ));
        }
        Ok(c)
    }

    /// Whether the compensator's own model (embedded, possibly refined in training) differs
    /// from `robot`: the compensator always runs in series with its own.
    pub fn runs_another_model(&self, robot: &Robot) -> bool {
        robot_to_toml(&self.robot) != robot_to_toml(robot)
    }

    /// Parses a compensator file's text given in code; errors name [`IN_MEMORY`].
    pub fn from_text(text: &str) -> Result<Compensator> {
        Self::from_file_text(text, Path::new(IN_MEMORY))
    }

    /// Parses a compensator file's bytes given in code (UTF-8 JSON); errors name
    /// [`IN_MEMORY`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Compensator> {
        let text = std::str::from_utf8(bytes).map_err(|e| {
            Error::input(
                Location::file(IN_MEMORY),
                format!("not a compensator file: not UTF-8 text ({e})"),
            )
        })?;
        Self::from_text(text)
    }

    /// Parses a compensator file's text; `path` names it in errors.
    pub fn from_file_text(text: &str, path: &Path) -> Result<Compensator> {
        let bad = |m: String| Error::input(Location::file(path), m);
        let mut v: Value = serde_json::from_str(crate::io::without_bom(text))
            .map_err(|e| bad(format!("not a compensator file: {e}")))?;
        if v["format"] != FORMAT {
            return Err(bad("not a robocal compensator file".into()));
        }
        let version = v["version"].as_u64().unwrap_or(0);
        if !(OLDEST..=VERSION).contains(&version) {
            return Err(bad(format!(
                "compensator file version {} (this robocal reads versions {OLDEST} to {VERSION}; \
                 train it again)",
                v["version"]
            )));
        }
        let sum = v["checksum"].as_str().unwrap_or_default().to_string();
        if let Some(o) = v.as_object_mut() {
            o.remove("checksum");
        }
        let body = serde_json::to_string(&v).map_err(|e| bad(e.to_string()))?;
        if format!("{:016x}", fnv1a(body.as_bytes())) != sum {
            return Err(bad(
                "checksum mismatch: the file is corrupt or was edited".into()
            ));
        }
        let robot_toml = v["robot_toml"]
            .as_str()
            .ok_or_else(|| bad("no embedded robot".into()))?;
        if format!("{:016x}", fnv1a(robot_toml.as_bytes()))
            != v["robot_hash"].as_str().unwrap_or_default()
        {
            return Err(bad("the embedded robot does not match its hash".into()));
        }
        let robot =
            crate::model::file::parse_robot(robot_toml, &path.with_extension("embedded.toml"))?;
        let get = |k: &str| {
            v[k].as_u64()
                .map(|x| x as usize)
                .ok_or_else(|| bad(format!("missing `{k}`")))
        };
        let (ni, nh, no) = (get("inputs")?, get("hidden")?, get("outputs")?);
        let records = v["network_records_burnpack_hex"]
            .as_array()
            .ok_or_else(|| bad("no network records".into()))?;
        let mut members = Vec::with_capacity(records.len());
        for (k, r) in records.iter().enumerate() {
            let bytes = unhex(r.as_str().unwrap_or_default())
                .ok_or_else(|| bad(format!("network record {} is not hex", k + 1)))?;
            let w = weights_from_record(&bytes, ni, nh, no).map_err(|e| bad(e.to_string()))?;
            // Finite but huge weights overflow in the first product: bound them too.
            if w.to_vector()
                .iter()
                .any(|x| x.is_nan() || x.abs() > VALUE_BOUND)
            {
                return Err(bad(format!(
                    "network {} has a non-finite weight or one beyond +-{VALUE_BOUND:e}",
                    k + 1
                )));
            }
            members.push(w);
        }
        // From version 7 each kernel names its covariance function: a kernel without one is
        // not read as the older files' squared exponential (it would predict otherwise).
        if version >= 7
            && let Some(kernels) = v["rbf"]["kernels"].as_array()
            && kernels.iter().any(|k| k.get("covariance").is_none())
        {
            return Err(bad(format!(
                "`rbf`: a kernel without its `covariance` in a version {version} file"
            )));
        }
        let rbf: Option<Rbf> = if version >= 5 {
            de(&v, "rbf", path)?
        } else if version >= 3 {
            de::<Option<SharedKernelRbf>>(&v, "rbf", path)?.map(Rbf::from)
        } else {
            None
        };
        if rbf.as_ref().is_some_and(|r| !r.is_valid(ni, no)) {
            return Err(bad(
                "the RBF network does not fit the inputs and outputs, or holds a non-finite or \
                 out-of-bounds number"
                    .into(),
            ));
        }
        let shrink: Option<Shrink> = if version >= 4 {
            de(&v, "shrink", path)?
        } else {
            None
        };
        if shrink
            .as_ref()
            .is_some_and(|s| !s.is_valid(no, members.len()))
        {
            return Err(bad(
                "the shrinkage does not fit the outputs or the members, or holds a non-finite \
                 or non-positive number"
                    .into(),
            ));
        }
        // Versions before 6 gave the MLPs and the RBF network equal say.
        let mlp_share = if version >= 6 {
            de::<f64>(&v, "mlp_share", path)?
        } else {
            MIX_SHARE
        };
        check_share(mlp_share).map_err(|e| bad(format!("`mlp_share`: {e}")))?;
        let model_refined = if version >= 8 {
            Some(de::<bool>(&v, "model_refined", path)?)
        } else {
            None
        };
        if members.is_empty() != (nh == 0) {
            return Err(bad(format!(
                "{} network records for {nh} hidden units",
                members.len()
            )));
        }
        fn de<T: serde::de::DeserializeOwned>(v: &Value, k: &str, path: &Path) -> Result<T> {
            serde_json::from_value(v[k].clone())
                .map_err(|e| Error::input(Location::file(path), format!("`{k}`: {e}")))
        }
        let c = Compensator {
            form: de::<Form>(&v, "form", path)?,
            encoding: de::<Encoding>(&v, "encoding", path)?,
            robot,
            members,
            rbf,
            mlp_share,
            shrink,
            input_norm: de::<Affine>(&v, "input_norm", path)?,
            output_norm: de::<Affine>(&v, "output_norm", path)?,
            domain: de::<Domain>(&v, "domain", path)?,
            model_refined,
        };
        // A consistent checksum does not prove consistent shapes or sane numbers: prediction
        // indexes by the shapes and would spread a non-finite number into every pose.
        let outputs_ok = match c.form {
            Form::Joint => no == c.robot.dof() && c.rbf.is_none(),
            Form::Pose => no == 3 || no == 6,
        };
        let norms_fit = c.input_norm.len() == ni && c.output_norm.len() == no;
        if ni != c.encoding.len(&c.robot) || !outputs_ok || !norms_fit {
            return Err(bad(format!(
                "a {ni}-{nh}-{no} {}-form network on {} inputs, with normalisations of {} \
                 inputs and {} outputs, does not fit its {}-joint robot",
                c.form.name(),
                c.encoding.name(),
                c.input_norm.len(),
                c.output_norm.len(),
                c.robot.dof()
            )));
        }
        // The outputs are corrections (mm, mrad, or um for prismatic joints): none reaches
        // 100 m or 100 rad.
        let physical = crate::model::MAX_LENGTH_MM;
        let outputs_bounded = c
            .output_norm
            .offset
            .iter()
            .chain(&c.output_norm.scale)
            .all(|v| v.abs() <= physical);
        if !c.input_norm.is_valid() || !c.output_norm.is_valid() || !outputs_bounded {
            return Err(bad(format!(
                "a normalisation holds a number out of bounds (scales positive, inputs within \
                 1e9, outputs within {physical:e})"
            )));
        }
        if !c.domain.is_valid(c.robot.dof(), ni) {
            return Err(bad(
                "the training domain does not fit the network or holds a non-finite number".into(),
            ));
        }
        Ok(c)
    }
}

/// FNV-1a, 64 bits: a checksum against corruption, not a cryptographic hash.
fn fnv1a(b: &[u8]) -> u64 {
    b.iter().fold(0xcbf29ce484222325u64, |h, &x| {
        (h ^ x as u64).wrapping_mul(0x100000001b3)
    })
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

fn unhex(s: &str) -> Option<Vec<u8>> {
    if !s.len().is_multiple_of(2) {
        return None;
    }
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(s.get(i..i + 2)?, 16).ok())
        .collect()
}
