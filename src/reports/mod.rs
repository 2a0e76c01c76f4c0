//! Typed reports: what `identify`, `train`, `evaluate`, `compensate`, `case-d` and
//! `reproduce` print and write (`--report`, JSON), one struct per command, declared in a
//! reader's order. The terminal output and the file come from the same value, and `report`
//! ([`html`], feature `report`) renders these types, not whatever JSON it finds.
//!
//! Every file is an object with a `kind` (`identify`, `train`, ...) and the fields of its
//! type. Lengths are mm, angles deg. A number that may be infinite (a condition number of a
//! rank-deficient problem, a cut of "no outliers") is written as the text `inf`; an absent
//! value is `null` and shown as "none".

pub mod compensate;
#[cfg(feature = "report")]
pub mod html;
pub mod identify;
mod node;
pub mod plan;
pub mod studies;
pub mod train;

pub use compensate::{CompensateReport, TargetFailure};
pub use identify::{Correlation, DroppedParam, EvaluateReport, IdentifyReport, Regroup};
pub use node::Node;
pub use plan::{PlanInputs, PlanReport};
pub use studies::{CaseDReport, ReproduceCase, ReproduceFigure, ReproduceReport, SeedFigure};
pub use train::TrainReport;

use crate::error::{Error, Location, Result};
use crate::evaluate::ErrorStats;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One row of an accuracy table: a model's errors on one data set. Before/after tables are
/// pairs of rows (`nominal` / `identified`, `model` / `+net`) on the same data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Accuracy {
    /// The data: `calibration`, `validation`, `training`, `test vs truth`, ...
    pub data: String,
    /// The model: `before` / `after`, `model` / `+net`, a case-d stage, ...
    pub model: String,
    /// Its errors (mm, deg).
    pub stats: ErrorStats,
    /// Rows outside the compensator's training domain, where one was used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rows_outside_domain: Option<usize>,
}

impl Accuracy {
    /// A row without a domain count.
    pub fn new(data: &str, model: &str, stats: ErrorStats) -> Accuracy {
        Accuracy {
            data: data.into(),
            model: model.into(),
            stats,
            rows_outside_domain: None,
        }
    }
}

/// Any report, tagged by `kind`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[allow(clippy::large_enum_variant)]
pub enum Report {
    /// `robocal identify`.
    Identify(IdentifyReport),
    /// `robocal train`.
    Train(TrainReport),
    /// `robocal evaluate`.
    Evaluate(EvaluateReport),
    /// `robocal compensate`.
    Compensate(CompensateReport),
    /// `robocal case-d`.
    #[serde(rename = "case-d")]
    CaseD(CaseDReport),
    /// `robocal reproduce`.
    Reproduce(ReproduceReport),
    /// `robocal plan`.
    Plan(PlanReport),
}

impl Report {
    /// The report's accuracy table, in the order the terminal shows it.
    pub fn accuracy(&self) -> Vec<Accuracy> {
        match self {
            Report::Identify(r) => r.accuracy.clone(),
            Report::Train(r) => r.accuracy.clone(),
            Report::Evaluate(r) => r.accuracy.clone(),
            Report::Compensate(_) => Vec::new(),
            Report::CaseD(r) => r.accuracy(),
            Report::Reproduce(_) | Report::Plan(_) => Vec::new(),
        }
    }

    /// The command that wrote it.
    pub fn kind(&self) -> &'static str {
        match self {
            Report::Identify(_) => "identify",
            Report::Train(_) => "train",
            Report::Evaluate(_) => "evaluate",
            Report::Compensate(_) => "compensate",
            Report::CaseD(_) => "case-d",
            Report::Reproduce(_) => "reproduce",
            Report::Plan(_) => "plan",
        }
    }

    /// The report as JSON text (pretty, a final newline), fields in declaration order.
    pub fn to_json(&self) -> Result<String> {
        let mut s = serde_json::to_string_pretty(self)
            .map_err(|e| Error::Invalid(format!("report: {e}")))?;
        s.push('\n');
        Ok(s)
    }

    /// Writes the report atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        crate::io::write_atomic(path, self.to_json()?.as_bytes())
    }

    /// Parses a report's JSON text; `path` names it in errors (with the line and column).
    pub fn from_json(text: &str, path: &Path) -> Result<Report> {
        serde_json::from_str(text).map_err(|e| {
            Error::input(
                Location {
                    file: path.to_path_buf(),
                    // A field of the wrong type inside a tagged report has no line (serde
                    // reads the report whole before it knows its kind).
                    line: (e.line() > 0).then_some(e.line()),
                    field: None,
                },
                format!("not a robocal report: {e}"),
            )
        })
    }

    /// The report's fields as an ordered tree (declaration order), for rendering.
    pub fn to_node(&self) -> Result<Node> {
        let text =
            serde_json::to_string(self).map_err(|e| Error::Invalid(format!("report: {e}")))?;
        serde_json::from_str(&text).map_err(|e| Error::Invalid(format!("report: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Cond {
        #[serde(with = "crate::io::json_number")]
        value: f64,
        zebra: Option<f64>,
        apple: usize,
    }

    #[test]
    fn infinite_numbers_round_trip_as_text_and_order_is_kept() {
        for v in [f64::INFINITY, f64::NEG_INFINITY, 2.5] {
            let c = Cond {
                value: v,
                zebra: None,
                apple: 1,
            };
            let text = serde_json::to_string(&c).unwrap();
            assert_eq!(serde_json::from_str::<Cond>(&text).unwrap(), c, "{text}");
            // Declaration order, not alphabetical: a reader's order.
            let node: Node = serde_json::from_str(&text).unwrap();
            let Node::Record(fields) = node else {
                panic!("a record")
            };
            let keys: Vec<&str> = fields.iter().map(|(k, _)| k.as_str()).collect();
            assert_eq!(keys, ["value", "zebra", "apple"]);
        }
        let text = serde_json::to_string(&Cond {
            value: f64::INFINITY,
            zebra: None,
            apple: 0,
        })
        .unwrap();
        assert!(text.contains("\"value\":\"inf\"") && text.contains("\"zebra\":null"));
        let bad = serde_json::from_str::<Cond>("{\"value\":\"lots\",\"zebra\":null,\"apple\":0}");
        assert!(
            bad.unwrap_err()
                .to_string()
                .contains("`lots` is not a number")
        );
    }

    #[test]
    fn a_json_file_that_is_no_report_is_refused_with_its_line() {
        let e = Report::from_json(
            "{\n\"kind\": \"identify\",\n\"robot\": 3,\n}",
            Path::new("r.json"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("r.json:4: not a robocal report"), "{e}");
        let e = Report::from_json(
            "{\n\"kind\": \"identify\",\n\"robot\": 3\n}",
            Path::new("r.json"),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("r.json: not a robocal report: invalid type"),
            "{e}"
        );
        let e = Report::from_json("{\"kind\": \"poem\"}", Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown variant `poem`"), "{e}");
    }
}
