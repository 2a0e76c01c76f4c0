//! How a compensator is built: its network kind, form and size ([`Settings`]), and what the
//! caller fixes or leaves to cross-validation ([`CompensatorOptions`]).

use super::encoding::Encoding;
use super::train::TrainOptions;
use crate::identify::Sigmas;

/// Default outlier cut: robust sigmas (1.4826 x the median, as `identify` scales its
/// outliers) of the chosen candidate's cross-validated error, position and orientation each
/// on its own, beyond which a training row is listed as an outlier (and, by default, left out
/// of the final fit). Under Gaussian noise a position error's norm has its median at 1.54
/// sigmas of a coordinate, so the cut lies near 11 sigmas of each coordinate and lists no
/// clean row. On real data the cross-validated error is mostly the network's, and the cut
/// trades one risk against the other. Too low, it leaves out good rows: a cut of 4 (before
/// the fifteenth session) listed 0.2-1.1 % of the real UR10 rows, on Series B every one for
/// its orientation error (4-6 sigmas) while its position was 0.3-3.7 sigmas off, the same
/// lines from split to split. Too high, it keeps a gross error (a reading wrong by a
/// millimetre or two; rows that carry another configuration's reading are found separately,
/// by [`crate::data::shared_readings`]) that the RBF network then bends its fit around.
/// Measured on Series B (three splits of 1000, five pool rows moved by 0, 1, 1.5 or 2 mm),
/// mean held-out RMS (mm) for cuts of 4 / 5 / 6 / 8: 0.2158 / 0.2122 / 0.2119 / 0.2119
/// clean, 0.2175 / 0.2160 / 0.2157 / 0.2158 with 1 mm, 0.2161 / 0.2124 / 0.2176 / 0.2258
/// with 1.5 mm, 0.2173 / 0.2136 / 0.2135 / 0.2285 with 2 mm: 5 is best or within 0.0003 mm
/// of it in every case. On 35 clean runs of Series A and B (pools of 500 to 2000) it lowered
/// the mean held-out RMS of every group against 4.
pub const OUTLIER_K: f64 = 5.0;

/// The MLPs' share of a mixed network's correction where nothing chose another
/// ([`Settings::mlp_share`] None outside cross-validation; the share of every compensator file
/// before version 6): equal say.
pub const MIX_SHARE: f64 = 0.5;

/// `share` as a blend's MLP share: strictly between 0 and 1 (0 is the RBF network alone, 1 the
/// MLPs alone), else an error.
pub fn check_share(share: f64) -> crate::error::Result<()> {
    if share > 0.0 && share < 1.0 {
        Ok(())
    } else {
        Err(crate::error::Error::Invalid(format!(
            "the MLPs' share {share} of a blend lies outside (0, 1): 0 is the RBF network \
             alone, 1 the MLPs alone"
        )))
    }
}

/// Where the network's output acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Form {
    /// Pose residual at the tool (robot base frame).
    Pose,
    /// Joint corrections before FK.
    Joint,
}

impl Form {
    /// Every form, joint first.
    pub const ALL: [Form; 2] = [Form::Joint, Form::Pose];

    /// Lower-case name, as in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Form::Pose => "pose",
            Form::Joint => "joint",
        }
    }
}

/// What kind of network a compensator carries.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Network {
    /// The thesis's multilayer perceptron: one logistic hidden layer, trained by momentum
    /// then Levenberg-Marquardt where its normal matrix is small, else L-BFGS
    /// ([`crate::neural::train::auto_phase2`]; an ensemble of them where it helps).
    #[default]
    Mlp,
    /// A radial-basis-function network with one unit per training row (at most
    /// [`super::train::TrainOptions::rbf_units`], on a choice of the rows), widths and weights
    /// of a Gaussian process's posterior mean per output ([`super::rbf`]); pose form only.
    Rbf,
    /// The MLPs' mean and an RBF network blended (pose form only; the MLPs' share
    /// [`Settings::mlp_share`]): the MLPs follow the smooth trend, the RBF network the sharp
    /// local structure (repeated configurations), and their errors are far from fully
    /// correlated.
    Mix,
}

impl Network {
    /// Lower-case name, as in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Network::Mlp => "mlp",
            Network::Rbf => "rbf",
            Network::Mix => "mix",
        }
    }
}

/// One complete choice of how to build a compensator.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "SettingsRead", into = "SettingsWrite")]
pub struct Settings {
    /// The network kind.
    pub network: Network,
    /// Where the network's output acts.
    pub form: Form,
    /// How joints become network inputs.
    pub encoding: Encoding,
    /// Hidden units of each MLP.
    pub hidden: usize,
    /// L2 weight penalty lambda (see [`super::samples`]).
    pub penalty: f64,
    /// MLPs in the ensemble (for `Rbf`: 1 with the RBF network); 0 and no RBF network: the
    /// (refined) model alone, chosen where cross-validation finds that no network lowers the
    /// held-out error by [`super::tuning::NETWORK_MARGIN`] or more and significantly row by
    /// row ([`super::tuning::NETWORK_Z`]).
    pub members: usize,
    /// The RBF network's hyperparameter search start ([`super::rbf::STARTS`], counted from 0
    /// here; reports write it from 1, as the command line counts it, as `rbf_search_start`);
    /// None: every start, the highest likelihood kept output by output.
    pub rbf_start: Option<usize>,
    /// Model parameters re-estimated on the training rows first (a selection as for
    /// `identify`), or None.
    pub refine: Option<String>,
    /// A mixed network's MLP share s (0 < s < 1, see [`super::compensator::Compensator`]);
    /// None: chosen by cross-validation among [`super::tuning::SHARES`] ([`MIX_SHARE`] in a
    /// fit of its own). Unused by the other networks.
    pub mlp_share: Option<f64>,
}

impl Settings {
    /// A one-line description: `joint/sincos/16 penalty 0.1 x5, refine full`.
    pub fn describe(&self) -> String {
        let refine = self
            .refine
            .as_ref()
            .map_or(String::new(), |r| format!(", refine {r}"));
        if !self.has_network() {
            return format!("model alone (no network){refine}");
        }
        let rbf = match self.rbf_start {
            Some(k) => format!("rbf start {}", k + 1),
            None => "rbf".into(),
        };
        match self.network {
            Network::Rbf => format!(
                "{}/{}/{rbf}{refine}",
                self.form.name(),
                self.encoding.name()
            ),
            Network::Mlp | Network::Mix => format!(
                "{}/{}/{} penalty {} x{}{}{refine}",
                self.form.name(),
                self.encoding.name(),
                self.hidden,
                self.penalty,
                self.members,
                match (self.network, self.mlp_share) {
                    (Network::Mix, Some(s)) => format!(" + {rbf}, MLP share {s}"),
                    (Network::Mix, None) => format!(" + {rbf}"),
                    _ => String::new(),
                }
            ),
        }
    }

    /// The network and its RBF search start, counted from 1 as in [`Settings::describe`]:
    /// `mlp`, `rbf 2`, `mix 1`; `none` for the model alone.
    pub fn network_label(&self) -> String {
        if !self.has_network() {
            return "none".into();
        }
        match (self.network, self.rbf_start) {
            (Network::Mlp, _) => "mlp".into(),
            (n, Some(k)) => format!("{} {}", n.name(), k + 1),
            (n, None) => n.name().into(),
        }
    }

    /// Whether these settings carry a network at all.
    pub fn has_network(&self) -> bool {
        self.members > 0 || self.network == Network::Mix
    }

    /// Whether these settings train MLPs (`hidden` and `penalty` mean something).
    pub fn has_mlp(&self) -> bool {
        match self.network {
            Network::Mlp => self.members > 0,
            Network::Rbf => false,
            Network::Mix => true,
        }
    }

    /// Whether these settings carry an RBF network.
    pub fn has_rbf(&self) -> bool {
        match self.network {
            Network::Mlp => false,
            Network::Rbf => self.members > 0,
            Network::Mix => true,
        }
    }
}

/// Whether to re-estimate model parameters with the network.
#[derive(Debug, Clone, PartialEq)]
pub enum Refine {
    /// [`Refine::Params`] of the full identifiable set ([`super::tuning::AUTO_REFINE`]):
    /// cross-validation decides among no refinement, the full set, and (unless
    /// [`CompensatorOptions::compliance`] says otherwise) the full set with the joints'
    /// gravity compliances ([`super::tuning::COMPLIANCE_MARGIN`]).
    Auto,
    /// Never.
    Off,
    /// These parameters (a selection as for `identify`), with the joints' gravity
    /// compliances as [`CompensatorOptions::compliance`] says; kept only where
    /// cross-validation shows that refinement lowers the held-out error. [`Refine::Auto`] is
    /// this for `full`.
    Params(String),
}

/// How to build a compensator: each choice left None is made by cross-validation.
#[derive(Debug, Clone)]
pub struct CompensatorOptions {
    /// The network kind; None: cross-validation decides (an RBF network is tried on the pose
    /// form, with at most [`super::train::TrainOptions::rbf_units`] units).
    pub network: Option<Network>,
    /// The RBF network's search start ([`super::rbf::STARTS`]); None: the first (smooth)
    /// start where cross-validation runs, else the highest likelihood, output by output.
    pub rbf_start: Option<usize>,
    /// Where the network's output acts; None: cross-validation decides.
    pub form: Option<Form>,
    /// How joints become network inputs; None: cross-validation decides.
    pub encoding: Option<Encoding>,
    /// Hidden units of each MLP; None: cross-validation decides.
    pub hidden: Option<usize>,
    /// L2 weight penalty lambda (dimensionless, see [`super::samples`]); None:
    /// cross-validation decides.
    pub penalty: Option<f64>,
    /// MLPs in the ensemble (0: no MLP); None: cross-validation decides.
    pub members: Option<usize>,
    /// The MLPs' share of a mixed network's correction (0 < s < 1); None: cross-validation
    /// decides.
    pub mlp_share: Option<f64>,
    /// Whether and which model parameters to re-estimate before training.
    pub refine: Refine,
    /// Whether the refinement adds the joints' gravity compliances (c1..cN where the model
    /// has masses, else the mass-free coefficients) to a selection that names none: None
    /// lets cross-validation decide (kept only by [`super::tuning::COMPLIANCE_MARGIN`]),
    /// `Some(true)` always adds them, `Some(false)` never does. A selection that names some
    /// refines them as named whatever this says.
    pub compliance: Option<bool>,
    /// Tracker sigmas for rows that carry none (refinement).
    pub sigmas: Sigmas,
    /// Cross-validation folds; None: 5, or 4 from 1500 distinct configurations.
    pub folds: Option<usize>,
    /// The training procedure of every network; its `hidden` and `penalty` are overridden by
    /// the settings.
    pub train: TrainOptions,
    /// Robust sigmas of the cross-validated error beyond which a training row is listed as
    /// an outlier ([`OUTLIER_K`]; infinite lists none). Applies where
    /// cross-validation runs.
    pub outlier_k: f64,
    /// Leave the listed outliers out of the final fit, and the training rows that carry
    /// another configuration's reading ([`crate::data::shared_readings`]) out of
    /// cross-validation and the fit (default true).
    pub drop_outliers: bool,
    /// Where the outliers left out weigh in the choice (one's held-out error alone makes more
    /// than [`super::tuning::RESELECT_SHARE`] of the chosen candidate's cross-validated
    /// squared position error), choose the settings again without them (default true; false
    /// keeps the choice made with them, for half the cross-validation's time).
    pub reselect: bool,
    /// Phase-2 epoch limits from the row count ([`super::tuning::CV_WORK`] for candidates,
    /// [`super::tuning::FIT_WORK`] for the final fit) instead of `train.max_epochs`.
    pub budget: bool,
    /// With every choice fixed and a network to train: cross-validate it all the same, and
    /// hold it against the model alone ([`super::selection::Selection::fixed_network_test`]),
    /// so that a fixed network that does worse than the model is told of. The compensator is
    /// the fixed one either way (no row is listed as an outlier, no search's
    /// hyperparameters are handed on). Default true; [`CompensatorOptions::fixed`] (a fit
    /// of settings already chosen) sets it false.
    pub test_fixed: bool,
}

impl Default for CompensatorOptions {
    fn default() -> Self {
        CompensatorOptions {
            network: None,
            rbf_start: None,
            form: None,
            encoding: None,
            hidden: None,
            penalty: None,
            members: None,
            mlp_share: None,
            refine: Refine::Auto,
            compliance: None,
            sigmas: Sigmas::default(),
            folds: None,
            train: TrainOptions::default(),
            outlier_k: OUTLIER_K,
            drop_outliers: true,
            reselect: true,
            budget: true,
            test_fixed: true,
        }
    }
}

impl CompensatorOptions {
    /// Options with every choice fixed.
    pub fn fixed(settings: &Settings, train: TrainOptions) -> Self {
        CompensatorOptions {
            network: Some(settings.network),
            rbf_start: settings.rbf_start,
            form: Some(settings.form),
            encoding: Some(settings.encoding),
            hidden: Some(settings.hidden),
            penalty: Some(settings.penalty),
            members: Some(settings.members),
            // A blend's share as its fit takes it: fixed, not left to cross-validation.
            mlp_share: (settings.network == Network::Mix)
                .then(|| settings.mlp_share.unwrap_or(MIX_SHARE)),
            refine: settings.refine.clone().map_or(Refine::Off, Refine::Params),
            // The chosen refinement names its compliances where it has them.
            compliance: Some(false),
            train,
            budget: false,
            test_fixed: false,
            ..Default::default()
        }
    }
}

/// [`Settings`] as reports write it: the search start counted from 1 (`rbf_search_start`);
/// the MLPs' `hidden` and `penalty` only where MLPs are trained (not for the RBF network
/// alone or the model alone, where they would read as a network of 0 units or an unused
/// penalty).
#[derive(serde::Serialize)]
struct SettingsWrite {
    network: Network,
    form: Form,
    encoding: Encoding,
    #[serde(skip_serializing_if = "Option::is_none")]
    hidden: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    penalty: Option<f64>,
    members: usize,
    #[serde(serialize_with = "counted_from_one::serialize")]
    rbf_search_start: Option<usize>,
    refine: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mlp_share: Option<f64>,
}

impl From<Settings> for SettingsWrite {
    fn from(s: Settings) -> SettingsWrite {
        let mlp = s.has_mlp();
        SettingsWrite {
            network: s.network,
            form: s.form,
            encoding: s.encoding,
            hidden: mlp.then_some(s.hidden),
            penalty: mlp.then_some(s.penalty),
            members: s.members,
            rbf_search_start: s.rbf_start,
            refine: s.refine,
            mlp_share: s.mlp_share,
        }
    }
}

/// [`Settings`] as reports hold it: the search start counted from 1 (`rbf_search_start`),
/// or from 0 under its former name (`rbf_start`, the reports of earlier versions); no
/// `hidden` or `penalty` where no MLP is trained (0 then, as the search sets them for the RBF
/// network alone).
#[derive(serde::Deserialize)]
struct SettingsRead {
    network: Network,
    form: Form,
    encoding: Encoding,
    #[serde(default)]
    hidden: usize,
    #[serde(default)]
    penalty: f64,
    members: usize,
    #[serde(default, deserialize_with = "counted_from_one::deserialize")]
    rbf_search_start: Option<usize>,
    #[serde(default)]
    rbf_start: Option<usize>,
    refine: Option<String>,
    #[serde(default)]
    mlp_share: Option<f64>,
}

impl From<SettingsRead> for Settings {
    fn from(r: SettingsRead) -> Settings {
        Settings {
            network: r.network,
            form: r.form,
            encoding: r.encoding,
            hidden: r.hidden,
            penalty: r.penalty,
            members: r.members,
            rbf_start: r.rbf_search_start.or(r.rbf_start),
            refine: r.refine,
            mlp_share: r.mlp_share,
        }
    }
}

/// An index kept from 0 that reports write from 1, as `--rbf-start` and
/// [`Settings::describe`] count it.
mod counted_from_one {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(k: &Option<usize>, s: S) -> Result<S::Ok, S::Error> {
        match k {
            Some(k) => s.serialize_some(&(k + 1)),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
        match Option::<usize>::deserialize(d)? {
            Some(0) => Err(serde::de::Error::custom(
                "rbf_search_start counts from 1, as --rbf-start does",
            )),
            k => Ok(k.map(|k| k - 1)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_count_the_rbf_start_from_one_as_the_command_line_does() {
        let s = Settings {
            network: Network::Mix,
            form: Form::Pose,
            encoding: Encoding::Gravity,
            hidden: 64,
            penalty: 1.0,
            members: 2,
            rbf_start: Some(0),
            refine: None,
            mlp_share: Some(0.05),
        };
        assert!(s.describe().contains("rbf start 1"), "{}", s.describe());
        let json = serde_json::to_string(&s).unwrap();
        assert!(json.contains("\"rbf_search_start\":1"), "{json}");
        assert_eq!(serde_json::from_str::<Settings>(&json).unwrap(), s);
        let every = Settings {
            rbf_start: None,
            ..s.clone()
        };
        let json = serde_json::to_string(&every).unwrap();
        assert!(json.contains("\"rbf_search_start\":null"), "{json}");
        assert_eq!(serde_json::from_str::<Settings>(&json).unwrap(), every);
        let zero = json.replace("\"rbf_search_start\":null", "\"rbf_search_start\":0");
        let e = serde_json::from_str::<Settings>(&zero)
            .unwrap_err()
            .to_string();
        assert!(e.contains("counts from 1"), "{e}");
        // An earlier version's report: the start counted from 0, under its former name.
        for (old, start) in [("0", Some(0)), ("2", Some(2)), ("null", None)] {
            let text = json.replace("\"rbf_search_start\":null", &format!("\"rbf_start\":{old}"));
            let read = serde_json::from_str::<Settings>(&text).unwrap();
            assert_eq!(read.rbf_start, start, "{text}");
        }
    }

    #[test]
    fn reports_give_the_mlp_size_and_penalty_only_where_mlps_are_trained() {
        let mlp = Settings {
            network: Network::Mlp,
            form: Form::Pose,
            encoding: Encoding::Gravity,
            hidden: 64,
            penalty: 1.0,
            members: 4,
            rbf_start: None,
            refine: None,
            mlp_share: None,
        };
        let json = serde_json::to_string(&mlp).unwrap();
        assert!(
            json.contains("\"hidden\":64") && json.contains("\"penalty\":1.0"),
            "{json}"
        );
        assert_eq!(serde_json::from_str::<Settings>(&json).unwrap(), mlp);
        // The RBF network alone, as the search sets it up (no units, no penalty).
        let rbf = Settings {
            network: Network::Rbf,
            hidden: 0,
            penalty: 0.0,
            members: 1,
            rbf_start: Some(0),
            ..mlp.clone()
        };
        let json = serde_json::to_string(&rbf).unwrap();
        assert!(
            !json.contains("hidden") && !json.contains("penalty"),
            "{json}"
        );
        assert_eq!(serde_json::from_str::<Settings>(&json).unwrap(), rbf);
        // The model alone, held against the best MLPs (their size kept in memory).
        let alone = Settings {
            members: 0,
            ..mlp.clone()
        };
        let json = serde_json::to_string(&alone).unwrap();
        assert!(
            !json.contains("hidden") && !json.contains("penalty"),
            "{json}"
        );
        assert!(json.contains("\"members\":0"), "{json}");
        assert_eq!(alone.network_label(), "none");
        assert_eq!(rbf.network_label(), "rbf 1");
        assert_eq!(
            serde_json::from_str::<Settings>(&json).unwrap().describe(),
            alone.describe()
        );
        // A blend trains MLPs.
        let mix = Settings {
            network: Network::Mix,
            mlp_share: Some(0.1),
            members: 2,
            ..mlp.clone()
        };
        let json = serde_json::to_string(&mix).unwrap();
        assert!(
            json.contains("\"hidden\":64") && json.contains("\"mlp_share\":0.1"),
            "{json}"
        );
        // An earlier version's report of the RBF network alone, with its zeros.
        let old = r#"{"network":"rbf","form":"pose","encoding":"gravity","hidden":0,"penalty":0.0,"members":1,"rbf_search_start":1,"refine":null}"#;
        assert_eq!(serde_json::from_str::<Settings>(old).unwrap(), rbf);
    }
}
