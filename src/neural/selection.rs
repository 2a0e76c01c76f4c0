//! What cross-validation did: every candidate's held-out errors, the choice, and the
//! training rows it found to be outliers.

use super::rbf::Hyper;
use super::settings::Settings;

/// A training row whose cross-validated error marks it an outlier.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Outlier {
    /// Index of the row in the training set (0-based).
    pub row: usize,
    /// Line of the row in its data file (0 for generated rows).
    pub line: usize,
    /// The chosen candidate's held-out errors on the row (mm, deg).
    pub position_mm: f64,
    /// Held-out orientation error on the row (deg); None for position-only data.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_deg: Option<f64>,
    /// The larger error in robust sigmas of its own column.
    pub robust_sigmas: f64,
}

/// Cross-validated errors of one candidate (mm, deg; RMS over every held-out row).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Score {
    /// RMS position error (mm).
    pub position_rms_mm: f64,
    /// RMS orientation error (deg); None for position-only data.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orientation_rms_deg: Option<f64>,
}

/// One cross-validated candidate.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Candidate {
    /// The search stage that proposed it (1 to 5, see [`super::tuning`]).
    pub stage: usize,
    /// The settings tried.
    pub settings: Settings,
    /// The settings as the table and the notes name them ([`Settings::describe`]): "model
    /// alone (no network)" for a candidate without a network, whose `settings` still carry
    /// the form and encoding of the network it was held against. Empty in reports written
    /// before it.
    #[serde(default)]
    pub label: String,
    /// None when the candidate failed on some fold (see `error`), was dropped early (see
    /// `pruned`) or is a proxy (see `proxy`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub score: Option<Score>,
    /// Why the candidate failed on some fold (the last failure's message), if it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Set instead of `score` when the candidate was dropped after the first
    /// [`RACE_FOLDS`](super::tuning::RACE_FOLDS) folds, or was only a proxy (`proxy`): its
    /// errors on those folds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pruned: Option<Score>,
    /// Scored on the race folds only, as a proxy, and never chosen: a blend's refinements
    /// are judged first by the RBF network alone there (stage 4), and only the best of them
    /// is tried with the blend.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub proxy: bool,
    /// Sums over the race folds: a scored candidate's are the yardstick for later ones; a
    /// proxy's rank the refinements of a blend.
    #[serde(skip)]
    pub(crate) race: Option<Sums>,
}

impl Candidate {
    /// Its errors on the race folds, the figure that ranks a blend's refinements: None when
    /// it failed there, or when it was read from a file (the sums are not saved).
    pub fn race_score(&self) -> Option<Score> {
        self.race.as_ref().map(Sums::score)
    }
}

impl Selection {
    /// Every row listed as an outlier, by row: those of a first choice made again without
    /// them ([`Selection::first_outliers`]) and those of the choice these figures are of.
    pub fn listed_outliers(&self) -> Vec<&Outlier> {
        let mut all: Vec<&Outlier> = self.first_outliers.iter().chain(&self.outliers).collect();
        all.sort_by_key(|o| o.row);
        all
    }
}

/// What cross-validation did.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Selection {
    /// Number of cross-validation folds k.
    pub folds: usize,
    /// The model alone on the same held-out rows.
    pub model: Score,
    /// Every candidate, in the order tried.
    pub candidates: Vec<Candidate>,
    /// Index of the chosen candidate.
    pub chosen: usize,
    /// What the user should know about the choice (ensemble size, no network, refinement
    /// dropped, outliers found).
    pub notes: Vec<String>,
    /// Training rows beyond `outlier_k` robust sigmas of the chosen candidate's held-out
    /// errors (the final fit leaves them out when the options say so, they are few enough
    /// to be mis-measured rows, and the fit without them is sound: `outliers_left_out`).
    pub outliers: Vec<Outlier>,
    /// Whether the final fit left `outliers` out (`first_outliers` always are).
    pub outliers_left_out: bool,
    /// Outliers of a first cross-validation on every row that weighed in its choice (one of
    /// them made more than [`RESELECT_SHARE`](crate::neural::tuning::RESELECT_SHARE) of the
    /// chosen candidate's squared position error alone): left out of the cross-validation whose
    /// figures these are, and of the final fit. Empty where there was no such first choice
    /// (and in reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub first_outliers: Vec<Outlier>,
    /// The cut, robust sigmas (infinite: no row is left out).
    #[serde(with = "crate::io::json_number")]
    pub outlier_k: f64,
    /// The chosen RBF network's hyperparameters, searched on the training rows (at most
    /// [`HYPER_BLOCKS`](crate::neural::rbf::HYPER_BLOCKS) blocks of
    /// [`HYPER_ROWS`](crate::neural::rbf::HYPER_ROWS) of them) for the model as given. When
    /// nothing is refined, the final fit reuses them, or begins its search at them when it
    /// leaves rows out; a refined model's final fit searches from the settings' start.
    #[serde(skip)]
    pub rbf_hyper: Option<Hyper>,
    /// The network chosen so far against the best model alone on the same held-out rows
    /// (stage 5 of [`super::tuning`]); None where no network was held against the model
    /// alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network_test: Option<NetworkTest>,
    /// The test of the network with an RBF network chosen after stages 1-4, where the rows no
    /// hyperparameter search saw failed it and `network_test` then held the best network
    /// without one against the model alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rbf_network_test: Option<NetworkTest>,
    /// Tests of a refinement cross-validation ranked first (stage 4 among the networks,
    /// stage 5 among the models alone) against the best candidate without it, in the form of
    /// [`NetworkTest`] (`network` the refined candidate, `alone` the one without the
    /// refinement): kept where lower by
    /// [`REFINEMENT_MARGIN`](super::tuning::REFINEMENT_MARGIN) and significantly lower row by
    /// row ([`REFINEMENT_Z`](super::tuning::REFINEMENT_Z)). Empty where no refinement ranked
    /// first (and in reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub refinement_tests: Vec<NetworkTest>,
    /// Where the options fix the network (`--members`): the network chosen against the best
    /// model alone, as [`Selection::network_test`] but kept whatever it says.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fixed_network_test: Option<NetworkTest>,
    /// What the user must know before using the compensator: a fixed network that the
    /// model alone beats in cross-validation.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// The network chosen after stages 1-4 of [`super::tuning`] against the best model alone (as
/// given or refined), row by row on the same held-out rows: the network is kept only if it is lower by
/// [`NETWORK_MARGIN`](super::tuning::NETWORK_MARGIN) in cross-validated RMS and significantly
/// lower row by row ([`NETWORK_Z`](super::tuning::NETWORK_Z)).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NetworkTest {
    /// Index of the network among the candidates.
    pub network: usize,
    /// Index of the best model alone among the candidates.
    pub alone: usize,
    /// The network's cross-validated position RMS over the model alone's, each as judged
    /// (times its refinement's margin, [`COMPLIANCE_MARGIN`](super::tuning::COMPLIANCE_MARGIN)).
    #[serde(with = "crate::io::json_number")]
    pub ratio: f64,
    /// Paired z of the rows' differences of squared position errors (network minus model
    /// alone, mm^2): their mean over its standard error, negative where the network is lower;
    /// each arm configuration weighed once (rows that repeat one configuration are averaged
    /// first, as they stay in one fold).
    /// Not a number where the held-out rows could not be recomputed as they were scored
    /// (the margin alone then decided).
    #[serde(with = "crate::io::json_number")]
    pub z: f64,
    /// Held-out rows compared (0: the test could not be run).
    pub rows: usize,
    /// The distinct arm configurations among them, each weighed once in `z` (0 in reports
    /// written before it).
    #[serde(default)]
    pub configurations: usize,
    /// Whether the network was kept: by `unseen`'s figures where that test ran.
    pub kept: bool,
    /// Where the network carries an RBF network and passed on the figures above (whose
    /// hyperparameters were searched on rows the folds hold out): the same test on held-out
    /// rows no hyperparameter search saw, which decides. None where it did not run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unseen: Option<UnseenTest>,
}

/// How [`UnseenTest`]'s rows were kept from the RBF hyperparameter search.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unseen {
    /// Each fold's hyperparameters searched on its training rows alone; every held-out row
    /// judged (where the search on all training rows drew every configuration, or left too
    /// few out).
    Folds,
    /// The held-out rows whose configurations the search on all training rows did not draw
    /// (where they are at least as many as a fold holds out).
    Rows,
}

/// [`NetworkTest`] of a network with an RBF network on held-out rows whose values neither its
/// weights nor its hyperparameters saw.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UnseenTest {
    /// How the rows were kept from the search.
    pub by: Unseen,
    /// The network's position RMS over the model alone's on those rows, each as judged.
    #[serde(with = "crate::io::json_number")]
    pub ratio: f64,
    /// Paired z on those rows, as [`NetworkTest::z`].
    #[serde(with = "crate::io::json_number")]
    pub z: f64,
    /// Rows compared.
    pub rows: usize,
    /// The distinct arm configurations among them, each weighed once in `z` (0 in reports
    /// written before it).
    #[serde(default)]
    pub configurations: usize,
}

/// Sums of squared errors over held-out rows.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Sums {
    pub pos: f64,
    pub rot: f64,
    pub rows: usize,
    pub with_rotation: bool,
}

impl Sums {
    pub fn add(&mut self, o: Sums) {
        self.pos += o.pos;
        self.rot += o.rot;
        self.rows += o.rows;
        self.with_rotation |= o.with_rotation;
    }

    pub fn score(&self) -> Score {
        let n = self.rows.max(1) as f64;
        Score {
            position_rms_mm: (self.pos / n).sqrt(),
            orientation_rms_deg: self.with_rotation.then(|| (self.rot / n).sqrt()),
        }
    }
}
