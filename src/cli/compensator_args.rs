//! Flags that build a compensator (`train`, `case-d`): every choice left out is made by
//! cross-validation on the training rows.

use super::choices::{Form, Network};
use anyhow::Result;
use clap::{Args, ValueEnum};
use robocal::neural::compensator::{CompensatorOptions, Refine};
use robocal::neural::encoding::Encoding;
use robocal::neural::rbf::{HYPER_BLOCKS, HYPER_ROWS, MAX_UNITS};
use robocal::neural::train::{Epoch, Phase2, Progress, TrainOptions};

/// Whether refinement adds the joints' gravity compliances, on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ComplianceArg {
    /// Tried, and kept only where they lower the cross-validated error by 2 % or more.
    Auto,
    /// Added to the selection (cross-validation still decides whether to refine at all).
    On,
    /// Not added.
    Off,
}

/// The error for a `--refine` selection that names compliances with `--compliance off`: a
/// usage error (exit 2).
pub fn compliance_conflict(spec: &str) -> anyhow::Error {
    anyhow::Error::new(super::Usage(format!(
        "--refine {spec} names compliances and --compliance off leaves them out: give one"
    )))
}

/// Input encodings on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum EncodingArg {
    /// sin and cos of each revolute joint angle.
    Sincos,
    /// The joint values (rad, mm).
    Angles,
    /// sin and cos, and gravity's direction in each link frame of the model.
    Gravity,
}

/// Phase-2 methods on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Phase2Arg {
    /// Levenberg-Marquardt when its normal matrix is cheap, L-BFGS beyond.
    Auto,
    /// Levenberg-Marquardt (MATLAB trainlm).
    Lm,
    /// L-BFGS.
    Lbfgs,
}

#[derive(Args, Debug, Clone)]
pub struct CompensatorArgs {
    /// The network: `mlp` (the thesis's multilayer perceptron, in ensembles where that
    /// helps), `rbf` (one unit per training row, at most --rbf-units, widths and weights of
    /// one Gaussian process's posterior mean per output; pose form only; its cost grows with
    /// the cube of the units) or
    /// `mix` (the MLPs' mean and an RBF network blended, the MLPs' share chosen by
    /// cross-validation unless --mlp-share fixes it; pose form only). Default: chosen by
    /// cross-validation. Without --members,
    /// cross-validation may still keep the model alone where no network is both 2 % better
    /// and significantly better row by row.
    #[arg(long, value_enum)]
    pub network: Option<Network>,
    /// Where the network acts: joint corrections before FK, or a pose residual after it
    /// (robot base frame). Default: chosen by cross-validation.
    #[arg(long, value_enum)]
    pub form: Option<Form>,
    /// Network inputs: sin/cos of the joints, the joint values, or sin/cos plus the direction
    /// of gravity in each link frame. Default: chosen by cross-validation.
    #[arg(long, value_enum)]
    pub encoding: Option<EncodingArg>,
    /// Hidden sigmoid units (1 to 256). Default: chosen by cross-validation among 16, 32, 64.
    #[arg(long, allow_negative_numbers = true)]
    pub hidden: Option<usize>,
    /// L2 weight penalty lambda (>= 0; one squared weight against one squared unit-scale
    /// residual). Default: chosen by cross-validation (0.1, 1, 10, then a factor 3 around the best).
    #[arg(long, allow_negative_numbers = true)]
    pub penalty: Option<f64>,
    /// Networks in the ensemble (0 to 50; the prediction is their mean; 0: the model alone,
    /// not with --network, --form, --encoding, --hidden, --penalty, the training flags
    /// --momentum-epochs, --max-epochs, --phase2, --goal, --max-fail, --validation-fraction,
    /// or --rbf-*).
    /// Default: 1 or 4 (2 blended with an RBF network, as cross-validation judged them), or
    /// none where no network lowers the error by 2 % or more and significantly row by row,
    /// by cross-validation.
    #[arg(long, allow_negative_numbers = true)]
    pub members: Option<usize>,
    /// Model parameters re-estimated on the training rows before the network is trained
    /// (exact identification): `auto`, `none`, or a selection as for identify (`offsets`,
    /// `full`, `full,compliance`, names). Cross-validation decides among no refinement, the
    /// selection, and (see --compliance) the selection with the joints' gravity
    /// compliances. `auto`: in `train` the selection `full`; in `case-d` each model's own
    /// parameters (without compliances unless --compliance on).
    #[arg(long, default_value = "auto")]
    pub refine: String,
    /// Whether the refinement adds the joints' gravity compliances (c1..cN where the robot
    /// file has masses, else mass-free coefficients) to a selection that names none: `auto`
    /// (tried, and kept only where they lower the cross-validated error by 2 % or more), `on`,
    /// or `off`. A selection that names compliances refines them as named (not with `off`).
    #[arg(long, value_enum, default_value = "auto")]
    pub compliance: ComplianceArg,
    /// Cross-validation folds (2 to 20). Default: 5, or 4 from 1500 distinct configurations.
    #[arg(long, allow_negative_numbers = true)]
    pub folds: Option<usize>,
    /// Seed of the folds, the initial weights and the held-out validation parts.
    #[arg(long, allow_negative_numbers = true, default_value_t = 1)]
    pub seed: u64,
    /// Phase-1 (gradient descent with momentum 0.9, learning rate 0.01) epochs (at most
    /// 100000).
    #[arg(long, allow_negative_numbers = true, default_value_t = 50)]
    pub momentum_epochs: usize,
    /// Phase-2 epoch limit (at most 100000; L-BFGS: ten iterations an epoch). Default: from
    /// the row count (50 epochs on 2000 rows, 60 on up to 1333).
    #[arg(long, allow_negative_numbers = true)]
    pub max_epochs: Option<usize>,
    /// Phase-2 method.
    #[arg(long, value_enum, default_value_t = Phase2Arg::Auto)]
    pub phase2: Phase2Arg,
    /// Performance goal: mean squared normalised residual (>= 0).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub goal: f64,
    /// Validation failures in a row before stopping (1 to 1000).
    #[arg(long, allow_negative_numbers = true, default_value_t = 6)]
    pub max_fail: usize,
    /// Part of each network's training rows held out for the thesis's validation-failure
    /// stopping rule (0 to 0.5; 0: none, the penalty regularises and every row trains).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub validation_fraction: f64,
    /// Training rows whose cross-validated error exceeds this many robust sigmas (1.4826 x
    /// the median) are listed as outliers (at least 2; `inf` lists none). Needs
    /// cross-validation: with every choice fixed, no row is listed.
    #[arg(long, allow_negative_numbers = true, default_value_t = robocal::neural::tuning::OUTLIER_K)]
    pub outlier_k: f64,
    /// Keep the listed outliers in the final fit, and the rows that carry another
    /// configuration's reading in cross-validation and the fit (default: leave them out; a
    /// mis-measured row would bend the RBF network's fit around it and spoil its neighbours).
    #[arg(long, conflicts_with = "drop_outliers")]
    pub keep_outliers: bool,
    /// Keep the choice of settings made with the outliers it lists, where they weigh in it
    /// (default: where one outlier's held-out error alone makes more than 4 % of the chosen
    /// settings' cross-validated squared position error, the settings are chosen again
    /// without the outliers, for twice the cross-validation's time).
    #[arg(long, conflicts_with = "keep_outliers")]
    pub first_choice: bool,
    /// The RBF network's likelihood search start, 1-3: widths of 1, 0.2 or 0.05 standard
    /// deviations (1, the smooth one, by default under cross-validation; a fixed network with
    /// nothing else open takes, output by output, the start of highest likelihood).
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=3))]
    pub rbf_start: Option<u8>,
    /// Rows of each block the RBF network's likelihood search sees at most, 2 to 3000 and to
    /// the units (default 500, or the units where fewer), one per arm configuration: on a larger training set a seeded choice of
    /// them, the other rows (and a configuration's repeats) entering its weights only. Its
    /// cost grows with the cube of the rows: on 2000 real UR10 poses, one block of 1000 rows
    /// instead of 500 lowered the held-out RMS by 5.5 % and took the default `train` from 4.5
    /// s to 11-15 s (squared-exponential kernel).
    #[arg(long, allow_negative_numbers = true)]
    pub rbf_search_rows: Option<usize>,
    /// Units the RBF network carries at most, 2 to 10000 (default 3000): on a larger training
    /// set they are centred on a seeded choice of its rows, one per arm configuration first,
    /// and the other rows train the MLPs only. Its fit's memory grows with the square of the
    /// units (72 MB per output at 3000, 800 MB at 10000; an output per core at once) and its
    /// time with the cube.
    #[arg(long, allow_negative_numbers = true)]
    pub rbf_units: Option<usize>,
    /// Disjoint blocks of those rows the likelihood search sees at most on a larger training
    /// set, their log likelihoods added, 1 to 8 (default 1; a last block of fewer rows only
    /// from half a block). Its cost grows with the blocks: on 2000 real UR10 poses, 2 blocks
    /// instead of 1 lowered the held-out RMS by 1.4 % and took the default `train` from 5.3 s
    /// to 7.1 s.
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=8))]
    pub rbf_search_blocks: Option<u8>,
    /// The RBF network's covariance function (default matern52: on the shipped UR10 data it
    /// lowered the held-out RMS against squared-exponential on every Series A split, by 2.8-8.5
    /// %, and by 1.2 % on the mean of 28 Series B runs).
    #[arg(long, value_enum)]
    pub rbf_kernel: Option<super::choices::RbfKernel>,
    /// Leave the listed outliers out of the final fit (the default; accepted for scripts
    /// written when keeping them was).
    #[arg(long)]
    pub drop_outliers: bool,
    /// The MLPs' share of a mixed network's correction, strictly between 0 and 1 (the RBF
    /// network has the rest). Default: chosen by cross-validation among 0.05, 0.1, ..., 0.95.
    #[arg(long, allow_negative_numbers = true)]
    pub mlp_share: Option<f64>,
    /// The ids of the flags given on the command line (set after parsing, [`super::main`]):
    /// a flag with a default cannot otherwise be told from its default.
    #[arg(skip)]
    pub given: Vec<String>,
}

impl CompensatorArgs {
    /// Whether the flag of id `id` (its field's name) was given on the command line.
    fn was_given(&self, id: &str) -> bool {
        self.given.iter().any(|g| g == id)
    }

    /// The MLPs' training flags and whether each was given (flags with a default count when
    /// given at it).
    fn training_flags(&self) -> [(&'static str, bool); 6] {
        [
            ("--max-epochs", self.max_epochs.is_some()),
            ("--momentum-epochs", self.was_given("momentum_epochs")),
            ("--phase2", self.was_given("phase2")),
            ("--goal", self.was_given("goal")),
            ("--max-fail", self.was_given("max_fail")),
            (
                "--validation-fraction",
                self.was_given("validation_fraction"),
            ),
        ]
    }

    /// The RBF network's flags and whether each was given.
    fn rbf_flags(&self) -> [(&'static str, bool); 5] {
        [
            ("--rbf-start", self.rbf_start.is_some()),
            ("--rbf-kernel", self.rbf_kernel.is_some()),
            ("--rbf-search-rows", self.rbf_search_rows.is_some()),
            ("--rbf-search-blocks", self.rbf_search_blocks.is_some()),
            ("--rbf-units", self.rbf_units.is_some()),
        ]
    }

    /// The library options; out-of-range values are refused with the flag's name.
    pub fn options(
        &self,
        sigmas: robocal::identify::Sigmas,
        progress: bool,
    ) -> Result<CompensatorOptions> {
        if let Some(h) = self.hidden
            && !(1..=256).contains(&h)
        {
            usage!("--hidden {h}: give 1 to 256 hidden units");
        }
        if let Some(p) = self.penalty
            && !(p.is_finite() && p >= 0.0)
        {
            usage!("--penalty {p}: give a finite penalty >= 0");
        }
        if let Some(m) = self.members
            && m > 50
        {
            usage!("--members {m}: give 0 to 50 networks");
        }
        if self.members == Some(0) {
            // The model alone: a flag that shapes a network would be dropped without a word.
            let shaping = [
                ("--network", self.network.is_some()),
                ("--form", self.form.is_some()),
                ("--encoding", self.encoding.is_some()),
                ("--hidden", self.hidden.is_some()),
                ("--penalty", self.penalty.is_some()),
            ]
            .into_iter()
            .chain(self.training_flags())
            .chain(self.rbf_flags());
            if let Some((flag, _)) = shaping.into_iter().find(|(_, given)| *given) {
                usage!("--members 0 keeps the model alone, no network: not with {flag}");
            }
        }
        if let Some(k) = self.folds
            && !(2..=20).contains(&k)
        {
            usage!("--folds {k}: give 2 to 20 folds");
        }
        if self.momentum_epochs > 100_000 || self.max_epochs.is_some_and(|m| m > 100_000) {
            usage!("--momentum-epochs and --max-epochs take at most 100000");
        }
        // No epoch in either phase would keep the random initial weights as the network.
        if self.momentum_epochs == 0 && self.max_epochs == Some(0) {
            usage!(
                "--momentum-epochs 0 with --max-epochs 0 trains no epoch: give one phase epochs"
            );
        }
        if !(self.goal.is_finite() && self.goal >= 0.0) {
            usage!("--goal {}: give a finite goal >= 0", self.goal);
        }
        if !(1..=1000).contains(&self.max_fail) {
            usage!("--max-fail {}: give 1 to 1000", self.max_fail);
        }
        if !(0.0..=0.5).contains(&self.validation_fraction) {
            usage!(
                "--validation-fraction {}: give a fraction from 0 to 0.5",
                self.validation_fraction
            );
        }
        if self.outlier_k.is_nan() || self.outlier_k < 2.0 {
            usage!(
                "--outlier-k {}: give a cut of at least 2 robust sigmas (inf keeps every row)",
                self.outlier_k
            );
        }
        let refine = match self.refine.as_str() {
            "auto" => Refine::Auto,
            "none" => Refine::Off,
            spec => Refine::Params(spec.to_string()),
        };
        let compliance = match self.compliance {
            ComplianceArg::Auto => None,
            ComplianceArg::On => Some(true),
            ComplianceArg::Off => Some(false),
        };
        if refine == Refine::Off && compliance == Some(true) {
            usage!("--compliance on refines the compliances: not with --refine none");
        }
        // The group by name here; named compliances (`c2`) against the robot in `train`.
        if compliance == Some(false) && self.refine.split(',').any(|s| s.trim() == "compliance") {
            return Err(compliance_conflict(&self.refine));
        }
        if let Some(n @ (Network::Rbf | Network::Mix)) = self.network
            && self.form == Some(Form::Joint)
        {
            usage!(
                "--network {} acts on the pose residual: use --form pose (or leave it out)",
                robocal::neural::settings::Network::from(n).name()
            );
        }
        // An RBF network acts on the pose form: its flags with `--form joint` would be
        // dropped without a word.
        if self.form == Some(Form::Joint)
            && let Some((flag, _)) = self.rbf_flags().into_iter().find(|(_, given)| *given)
        {
            usage!(
                "{flag} sets up the RBF network, which acts on the pose residual: not with \
                 --form joint"
            );
        }
        if self.rbf_start.is_some() && self.network == Some(Network::Mlp) {
            usage!("--rbf-start sets up the RBF network: not with --network mlp");
        }
        if self.rbf_kernel.is_some() && self.network == Some(Network::Mlp) {
            usage!("--rbf-kernel sets up the RBF network: not with --network mlp");
        }
        let units = self.rbf_units.unwrap_or(MAX_UNITS);
        if let Some(u) = self.rbf_units {
            if !(2..=10_000).contains(&u) {
                usage!("--rbf-units {u}: give 2 to 10000 units");
            }
            if self.network == Some(Network::Mlp) {
                usage!("--rbf-units sets up the RBF network: not with --network mlp");
            }
        }
        // The search's cost is cubic in its rows, at every one of its steps: no more than the
        // units, nor than 3000 (the largest before units were bounded).
        let search_max = units.min(3000);
        if let Some(rows) = self.rbf_search_rows {
            if !(2..=search_max).contains(&rows) {
                usage!(
                    "--rbf-search-rows {rows}: give 2 to {search_max} rows (at most the units, \
                     --rbf-units, and 3000)"
                );
            }
            if self.network == Some(Network::Mlp) {
                usage!("--rbf-search-rows sets up the RBF network: not with --network mlp");
            }
        }
        if self.rbf_search_blocks.is_some() && self.network == Some(Network::Mlp) {
            usage!("--rbf-search-blocks sets up the RBF network: not with --network mlp");
        }
        if let Some(share) = self.mlp_share {
            if let Err(e) = robocal::neural::settings::check_share(share) {
                usage!("--mlp-share {share}: {e}");
            }
            if matches!(self.network, Some(Network::Mlp | Network::Rbf))
                || self.members == Some(0)
                || self.form == Some(Form::Joint)
            {
                usage!(
                    "--mlp-share blends MLPs with an RBF network (pose form): not without both, \
                     nor with --form joint"
                );
            }
        }
        if self.network == Some(Network::Rbf) {
            if self.hidden.is_some() || self.penalty.is_some() {
                usage!(
                    "--hidden and --penalty set up an MLP; an RBF network has one unit per \
                     training row (up to --rbf-units) and fits its own noise level"
                );
            }
            if self.members.is_some_and(|m| m > 1) {
                usage!("--network rbf: --members takes 1 (the RBF network is deterministic)");
            }
            // The RBF network is solved, not trained by epochs: the MLPs' training flags
            // would be dropped without a word.
            if let Some((flag, _)) = self.training_flags().into_iter().find(|(_, given)| *given) {
                usage!(
                    "--network rbf is solved, not trained by epochs (its weights by Cholesky, its \
                     widths by maximum likelihood): not with {flag}"
                );
            }
        }
        Ok(CompensatorOptions {
            network: self.network.map(Into::into),
            rbf_start: self.rbf_start.map(|k| usize::from(k) - 1),
            form: self.form.map(Into::into),
            encoding: self.encoding.map(|e| match e {
                EncodingArg::Sincos => Encoding::SinCos,
                EncodingArg::Angles => Encoding::Angles,
                EncodingArg::Gravity => Encoding::Gravity,
            }),
            hidden: self.hidden,
            penalty: self.penalty,
            members: self.members,
            mlp_share: self.mlp_share,
            refine,
            compliance,
            sigmas,
            folds: self.folds,
            train: TrainOptions {
                seed: self.seed,
                momentum_epochs: self.momentum_epochs,
                max_epochs: self.max_epochs.unwrap_or(50),
                goal: self.goal,
                max_fail: self.max_fail,
                validation_fraction: self.validation_fraction,
                phase2: match self.phase2 {
                    Phase2Arg::Auto => Phase2::Auto,
                    Phase2Arg::Lm => Phase2::Lm,
                    Phase2Arg::Lbfgs => Phase2::Lbfgs,
                },
                progress: progress.then(epoch_bar),
                rbf_search_rows: self.rbf_search_rows.unwrap_or(HYPER_ROWS.min(units)),
                rbf_search_blocks: self.rbf_search_blocks.map_or(HYPER_BLOCKS, usize::from),
                rbf_units: units,
                rbf_covariance: self
                    .rbf_kernel
                    .map_or(robocal::neural::rbf::Covariance::DEFAULT, Into::into),
                ..Default::default()
            },
            outlier_k: self.outlier_k,
            drop_outliers: !self.keep_outliers,
            reselect: !self.first_choice,
            budget: self.max_epochs.is_none(),
            test_fixed: true,
        })
    }
}

/// A progress bar over cross-validation trainings on a terminal, hidden elsewhere.
pub fn progress_bar(show: bool) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(0);
    b.set_style(
        indicatif::ProgressStyle::with_template("cross-validation {bar:30} {pos}/{len} trainings")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// A progress bar over a network's epochs, drawn from the library's [`Progress`] callback
/// (created at the first epoch, cleared at the last).
fn epoch_bar() -> Progress {
    let bar: std::sync::Mutex<Option<indicatif::ProgressBar>> = std::sync::Mutex::new(None);
    Progress(std::sync::Arc::new(move |e: &Epoch| {
        let Ok(mut slot) = bar.lock() else { return };
        if e.finished {
            if let Some(b) = slot.take() {
                b.finish_and_clear();
            }
            return;
        }
        let b = slot.get_or_insert_with(|| {
            let b = indicatif::ProgressBar::new(e.total as u64);
            b.set_style(
                indicatif::ProgressStyle::with_template("{bar:30} epoch {pos}/{len} {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        });
        b.set_position(e.done as u64);
        b.set_message(format!(
            "train {:.3e} validation {:.3e}",
            e.train_mse, e.validation_mse
        ));
    }))
}
