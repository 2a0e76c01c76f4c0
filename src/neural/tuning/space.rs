//! What the options leave open: the lists each stage of the search draws from, the settings
//! it starts from, and the refinements tried.

use super::{AUTO_REFINE, HIDDEN, PENALTIES};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::neural::encoding::Encoding;
use crate::neural::settings::{CompensatorOptions, Form, Network, Refine, Settings, check_share};

/// Whether selection `spec` names compliance parameters of `robot`; an error where it does
/// not parse.
pub fn names_compliance(robot: &Robot, spec: &str) -> Result<bool> {
    let (completed, chosen, _) = crate::identify::candidates(robot, spec)?;
    let params = completed.parameters();
    Ok(chosen
        .iter()
        .any(|&i| crate::identify::select::is_compliance(&params[i])))
}

/// The refinements tried for selection `spec` (besides none), and the one cross-validation
/// added the joints' gravity compliances to on its own (judged by [`super::COMPLIANCE_MARGIN`]):
/// `spec` alone where it `names` compliances (they are refined as named) or `compliance` is
/// `Some(false)`; `spec` with them where `Some(true)`; both where None.
pub(super) fn refinements(
    spec: &str,
    names: bool,
    compliance: Option<bool>,
) -> (Vec<Option<String>>, Option<String>) {
    let with = format!("{spec},compliance");
    match (names, compliance) {
        (true, _) | (_, Some(false)) => (vec![None, Some(spec.into())], None),
        (false, Some(true)) => (vec![None, Some(with)], None),
        (false, None) => (
            vec![None, Some(spec.into()), Some(with.clone())],
            Some(with),
        ),
    }
}

/// What the options leave open: the lists each stage of the search draws from, the
/// settings it starts from, and whether anything is open at all.
pub(super) struct Space {
    pub(super) refines: Vec<Option<String>>,
    /// The refinement with the joints' gravity compliances that cross-validation adds on its
    /// own (kept only by [`super::COMPLIANCE_MARGIN`]).
    pub(super) auto_compliance: Option<String>,
    pub(super) rbf_only: bool,
    pub(super) mix_only: bool,
    pub(super) forms: Vec<Form>,
    pub(super) encodings: Vec<Encoding>,
    pub(super) hiddens: Vec<usize>,
    pub(super) penalties: Vec<f64>,
    pub(super) base: Settings,
    /// The RBF network's search start tried by cross-validation; None where every choice
    /// is fixed and none given: the fixed network's fit takes, output by output, the start
    /// of highest likelihood, and its test against the model alone scores that network.
    pub(super) rbf_start: Option<usize>,
    pub(super) try_rbf: bool,
    /// The RBF network alone may be a candidate: not where the MLPs' hidden units or
    /// penalty are given (those set up MLPs, which the RBF network alone has none of).
    pub(super) rbf_alone: bool,
    pub(super) open: bool,
}

impl Space {
    pub(super) fn of(robot: &Robot, opts: &CompensatorOptions) -> Result<Space> {
        if let Some(s) = opts.mlp_share {
            check_share(s)?;
        }
        let (refines, auto_compliance) = match &opts.refine {
            Refine::Off if opts.compliance == Some(true) => {
                return Err(Error::Invalid(
                    "the joints' gravity compliances are refined with a selection: not without \
                     refinement"
                        .into(),
                ));
            }
            Refine::Off => (vec![None], None),
            Refine::Auto => refinements(AUTO_REFINE, false, opts.compliance),
            Refine::Params(p) => {
                // A selection that does not parse is refused before any fit, not reported
                // as a failed candidate.
                let names = names_compliance(robot, p)
                    .map_err(|e| Error::Invalid(format!("the refinement `{p}`: {e}")))?;
                refinements(p, names, opts.compliance)
            }
        };
        let rbf_only = opts.network == Some(Network::Rbf);
        let mix_only = opts.network == Some(Network::Mix);
        if (rbf_only || mix_only) && opts.form == Some(Form::Joint) {
            return Err(Error::Invalid(
                "an RBF network acts on the pose residual: it has no joint form".into(),
            ));
        }
        let mut forms: Vec<Form> = match opts.form {
            Some(f) => vec![f],
            None if rbf_only || mix_only => vec![Form::Pose],
            None => Form::ALL.to_vec(),
        };
        let mut encodings: Vec<Encoding> =
            opts.encoding.map_or(Encoding::ALL.to_vec(), |e| vec![e]);
        let fixed = |v: Option<usize>, all: &[usize]| v.map_or(all.to_vec(), |h| vec![h]);
        let mut hiddens: Vec<usize> = if rbf_only {
            vec![0]
        } else {
            fixed(opts.hidden, &HIDDEN)
        };
        let mut penalties: Vec<f64> = match opts.penalty {
            _ if rbf_only => vec![0.0],
            Some(p) => vec![p],
            None => PENALTIES.to_vec(),
        };
        let base = if rbf_only {
            Settings {
                network: Network::Rbf,
                form: Form::Pose,
                encoding: opts.encoding.unwrap_or(Encoding::Angles),
                hidden: 0,
                penalty: 0.0,
                members: opts.members.unwrap_or(1).min(1),
                rbf_start: opts.rbf_start,
                refine: refines[0].clone(),
                mlp_share: None,
            }
        } else {
            Settings {
                network: Network::Mlp,
                form: forms[0],
                encoding: opts.encoding.unwrap_or(Encoding::Gravity),
                hidden: opts.hidden.unwrap_or(HIDDEN[1]),
                penalty: opts.penalty.unwrap_or(PENALTIES[1]),
                members: opts.members.unwrap_or(1),
                rbf_start: opts.rbf_start,
                refine: refines[0].clone(),
                mlp_share: None,
            }
        };
        if opts.members == Some(0) {
            // The model alone has no network whose form, inputs, size or penalty could
            // differ: one candidate per refinement, not one per network setting.
            forms = vec![base.form];
            encodings = vec![base.encoding];
            hiddens = vec![base.hidden];
            penalties = vec![base.penalty];
        }
        // An RBF network (alone or with the MLPs) is tried where the network is left open
        // (and not fixed at none, `members` 0: the model alone), on the pose form; on a large
        // set its units sit on a choice of the rows (`TrainOptions::rbf_units`).
        let try_rbf =
            opts.network.is_none() && opts.members != Some(0) && forms.contains(&Form::Pose);
        let open = refines.len() > 1
            || forms.len() > 1
            || encodings.len() > 1
            || hiddens.len() > 1
            || penalties.len() > 1
            || opts.members.is_none()
            || try_rbf
            || (mix_only && opts.mlp_share.is_none() && opts.members != Some(0));
        // The smooth start only, unless one is asked for: each start costs a search per
        // output, and with a kernel per output the smooth start's cross-validated error was
        // the lowest or within 0.8 % of it on the Series B pools tried (500 rows, seeds 0-2:
        // 0.286 against 0.296; 0.253 against 0.251; 0.244 against 0.265 mm).
        let rbf_start = if open {
            Some(opts.rbf_start.unwrap_or(0))
        } else {
            opts.rbf_start
        };
        Ok(Space {
            refines,
            auto_compliance,
            rbf_only,
            mix_only,
            forms,
            encodings,
            hiddens,
            penalties,
            base,
            rbf_start,
            try_rbf,
            rbf_alone: opts.hidden.is_none() && opts.penalty.is_none(),
            open,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refinements_add_the_compliances_as_asked() {
        let robot = crate::model::test_ur10();
        let refinements =
            |spec: &str, c| refinements(spec, names_compliance(&robot, spec).unwrap(), c);
        let s = |v: &[&str]| -> Vec<Option<String>> {
            std::iter::once(None)
                .chain(v.iter().map(|x| Some(x.to_string())))
                .collect()
        };
        let with = Some("full,compliance".to_string());
        assert_eq!(
            refinements("full", None),
            (s(&["full", "full,compliance"]), with.clone())
        );
        assert_eq!(refinements("full", Some(false)), (s(&["full"]), None));
        assert_eq!(
            refinements("full", Some(true)),
            (s(&["full,compliance"]), None)
        );
        // Named compliances are refined as named, whatever the flag.
        for c in [None, Some(true), Some(false)] {
            assert_eq!(refinements("full,k2.mx3", c), (s(&["full,k2.mx3"]), None));
        }
        assert!(!names_compliance(&robot, "offsets").unwrap());
        assert!(names_compliance(&robot, "offsets,compliance").unwrap());
        assert!(names_compliance(&robot, "no_such_parameter").is_err());
    }
}
