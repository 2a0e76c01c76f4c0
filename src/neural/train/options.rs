//! What training is told (its options, the phase-2 method, a progress callback) and what it
//! reports (the epochs taken, why it stopped, the training curve).

use crate::neural::weights::Weights;

/// The weight-refining phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase2 {
    /// Levenberg-Marquardt while its dense normal matrix is cheap to form and factorise
    /// (residual components x weights^2 + weights^3 / 3 <= [`LM_BUDGET`]), L-BFGS beyond.
    #[default]
    Auto,
    /// Levenberg-Marquardt (MATLAB trainlm), the thesis's.
    Lm,
    /// L-BFGS on the same penalised objective.
    Lbfgs,
}

/// Largest work of one LM epoch, residual components x weights^2 (the normal matrix) plus
/// weights^3 / 3 (its factorisation), for which `Phase2::Auto` uses Levenberg-Marquardt (a
/// few milliseconds per epoch on one core); beyond it an LM epoch costs more than a whole
/// L-BFGS run. Without the factorisation's part, a few rows chose LM for hundreds of
/// weights: 18 s to train on 7 rows against 1.3 s on 150.
pub const LM_BUDGET: f64 = 3e7;

/// What [`Phase2::Auto`] runs for `components` residual components and `weights` weights.
pub fn auto_phase2(components: usize, weights: usize) -> Phase2 {
    let (m, w) = (components as f64, weights as f64);
    if m * w * w + w * w * w / 3.0 <= LM_BUDGET {
        Phase2::Lm
    } else {
        Phase2::Lbfgs
    }
}

/// Where training stands, told after every epoch (and once more, `finished`, at the end).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch {
    /// Epochs done of both phases, out of at most `total`.
    pub done: usize,
    /// Most epochs of both phases: phase-1 epochs plus the phase-2 limit.
    pub total: usize,
    /// Mean squared normalised residual of the training and the held-out rows.
    pub train_mse: f64,
    /// Held-out MSE (normalised outputs); without a held-out part, the penalised training
    /// objective per residual component.
    pub validation_mse: f64,
    /// True on the last report, after training ended.
    pub finished: bool,
}

/// A callback told each [`Epoch`] (a progress bar, a log): the library draws nothing itself.
#[derive(Clone)]
pub struct Progress(pub std::sync::Arc<dyn Fn(&Epoch) + Send + Sync>);

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(callback)")
    }
}

/// Where an RBF network's hyperparameters ([`crate::neural::rbf::Hyper`]: log widths, signal and
/// noise variances, output after output) come from.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum RbfHyper {
    /// Searched: from the settings' start, or from every start when the settings name none
    /// ([`crate::neural::rbf::search_without`], [`crate::neural::rbf::search_best_without`]).
    #[default]
    Search,
    /// Given: found before on the same rows, not searched.
    Given(nalgebra::DVector<f64>),
    /// Searched beginning at these: those of a search on nearly the same rows
    /// ([`crate::neural::rbf::search_from`]).
    From(nalgebra::DVector<f64>),
}

/// Training settings.
#[derive(Debug, Clone)]
pub struct TrainOptions {
    /// Hidden units of the MLP.
    pub hidden: usize,
    /// Seed of the initial weights and of the held-out draw.
    pub seed: u64,
    /// Phase-1 epochs (full batch).
    pub momentum_epochs: usize,
    /// Phase-2 epoch limit (L-BFGS: ten iterations an epoch).
    pub max_epochs: usize,
    /// Performance goal (MSE of normalised outputs).
    pub goal: f64,
    /// Smallest gradient before stopping: the largest |J^T e| component.
    pub min_grad: f64,
    /// Validation failures in a row before stopping.
    pub max_fail: usize,
    /// Part of the training rows held out for the validation-failure rule (whole groups);
    /// 0 (the default): none, every row trains and the L2 penalty regularises (early stopping
    /// on a held-out part stopped networks well short of the penalised optimum and raised the
    /// real UR10 held-out RMS by 12 %).
    pub validation_fraction: f64,
    /// L2 weight penalty lambda (see [`crate::neural::samples`]); 0: none.
    pub penalty: f64,
    /// The weight-refining method of phase 2.
    pub phase2: Phase2,
    /// Told every epoch; None: nothing is told.
    pub progress: Option<Progress>,
    /// Weights to start from instead of the seeded initial ones (a warm start: the same
    /// network trained with another penalty); ignored when their shape does not fit.
    pub start: Option<Weights>,
    /// Where an RBF network's hyperparameters come from.
    pub rbf_hyper: RbfHyper,
    /// Rows of a larger set this one was taken from without (indices in that set): an RBF
    /// search runs on the rows the larger set's search draws, but these
    /// ([`crate::neural::rbf::search_without`]); empty: the set is whole.
    /// [`Compensator::train`](crate::neural::compensator::Compensator::train) sets it (and
    /// `rbf_hyper`, `rbf_whole_groups`) for its final fit, whatever the caller gave.
    pub rbf_left_out: Vec<usize>,
    /// The larger set's configuration group of each of its rows (its
    /// [`Samples::groups`](crate::neural::samples::Samples::groups)), so that the search draws that
    /// set's one row per configuration ([`crate::neural::rbf::LeftOut`]); empty: this set's groups,
    /// each row of `rbf_left_out` a configuration of its own.
    pub rbf_whole_groups: Vec<usize>,
    /// Rows an RBF network's hyperparameter search sees at most (one per arm configuration, a
    /// seeded choice of them on larger sets, the same in cross-validation and in the final
    /// fit; at least 2): default
    /// [`crate::neural::rbf::HYPER_ROWS`]. The search's cost is cubic in them.
    pub rbf_search_rows: usize,
    /// Disjoint blocks of `rbf_search_rows` an RBF network's hyperparameter search sees at
    /// most on larger sets, their likelihoods added (at least 1): default
    /// [`crate::neural::rbf::HYPER_BLOCKS`]. The search's cost is linear in them.
    pub rbf_search_blocks: usize,
    /// The RBF network's covariance function: default [`crate::neural::rbf::Covariance::DEFAULT`]
    /// (Matern 5/2).
    pub rbf_covariance: crate::neural::rbf::Covariance,
    /// Units an RBF network carries at most (at least 2): on a set of more rows they are
    /// centred on a seeded choice of its rows ([`crate::neural::rbf::unit_rows`]); default
    /// [`crate::neural::rbf::MAX_UNITS`]. The fit's cost is cubic in them.
    pub rbf_units: usize,
}

impl TrainOptions {
    /// The rows an RBF network's hyperparameter search sees (up to `rbf_search_blocks`
    /// blocks of `rbf_search_rows` of the set, drawn by `seed`) and its covariance function.
    pub fn rbf_draw(&self) -> crate::neural::rbf::Draw {
        crate::neural::rbf::Draw {
            seed: self.seed,
            rows: self.rbf_search_rows,
            covariance: self.rbf_covariance,
            blocks: self.rbf_search_blocks,
        }
    }
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            hidden: 20,
            seed: 1,
            momentum_epochs: 50,
            max_epochs: 60,
            goal: 0.0,
            min_grad: 1e-7,
            max_fail: 6,
            validation_fraction: 0.0,
            penalty: 0.0,
            phase2: Phase2::Auto,
            progress: None,
            start: None,
            rbf_hyper: RbfHyper::Search,
            rbf_left_out: Vec::new(),
            rbf_whole_groups: Vec::new(),
            rbf_search_rows: crate::neural::rbf::HYPER_ROWS,
            rbf_search_blocks: crate::neural::rbf::HYPER_BLOCKS,
            rbf_covariance: crate::neural::rbf::Covariance::DEFAULT,
            rbf_units: crate::neural::rbf::MAX_UNITS,
        }
    }
}

/// Why training stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrainStop {
    /// The training MSE reached `goal`.
    Goal,
    /// The gradient fell below `min_grad`.
    MinGradient,
    /// The held-out error did not improve for `max_fail` epochs in a row (best epoch kept).
    ValidationFailures,
    /// The phase-2 epoch limit `max_epochs` was reached.
    MaxEpochs,
    /// mu exceeded 1e10 (LM), or no step lowers the error (L-BFGS line search).
    MuMax,
}

impl TrainStop {
    /// A short phrase for reports: why training stopped.
    pub fn describe(self) -> &'static str {
        match self {
            TrainStop::Goal => "performance goal reached",
            TrainStop::MinGradient => "minimum gradient reached",
            TrainStop::ValidationFailures => "held-out error stopped improving (best epoch kept)",
            TrainStop::MaxEpochs => "epoch limit",
            TrainStop::MuMax => "no step lowers the error any more",
        }
    }
}

/// What training did.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct TrainReport {
    /// Why training stopped.
    pub stop: TrainStop,
    /// Phase-1 (momentum) epochs run.
    pub momentum_epochs: usize,
    /// Phase-2 epochs (L-BFGS: iterations).
    pub lm_epochs: usize,
    /// The phase-2 method used.
    pub phase2: Phase2,
    /// Final MSE (normalised outputs, no penalty) on the training part, and on the held-out
    /// part when there is one.
    pub train_mse: f64,
    /// Final MSE on the held-out part (normalised outputs); None when nothing was held out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub validation_mse: Option<f64>,
    /// (epoch, training MSE, validation MSE) over both phases.
    pub curve: Vec<(usize, f64, f64)>,
}
