//! Rows whose results depend on parameters the model's calibration did not observe
//! ([`robocal::kinematics::unobserved`]), gathered while a command runs and warned about once.

use robocal::kinematics::UnobservedProbe;
use robocal::model::Robot;
use robocal::reports::compensate::UncheckedLines;
use std::path::Path;

/// The rows (file lines) whose position or orientation depends on an unobserved parameter.
pub struct UncheckedRows {
    probe: UnobservedProbe,
    names: Vec<String>,
    position: Vec<usize>,
    orientation: Vec<usize>,
}

impl UncheckedRows {
    /// For results of `robot` (its unobserved parameters).
    pub fn new(robot: &Robot) -> UncheckedRows {
        UncheckedRows {
            probe: UnobservedProbe::new(robot),
            names: robot.unobserved().iter().map(|p| p.name()).collect(),
            position: Vec::new(),
            orientation: Vec::new(),
        }
    }

    /// Checks the row at file `line` with joints `q` (rad or mm) of `robot` (the probe's);
    /// `orientation`: whether the row's result includes an orientation that matters.
    pub fn add(&mut self, robot: &Robot, q: &[f64], line: usize, orientation: bool) {
        self.add_measured(robot, q, line, true, orientation);
    }

    /// [`UncheckedRows::add`] for a result whose position matters only where `position` holds
    /// (an orientation measure prints no position).
    pub fn add_measured(
        &mut self,
        robot: &Robot,
        q: &[f64],
        line: usize,
        position: bool,
        orientation: bool,
    ) {
        if self.probe.is_empty() {
            return;
        }
        let u = self.probe.at(robot, q);
        if u.position && position {
            self.position.push(line);
        }
        if u.orientation && orientation {
            self.orientation.push(line);
        }
    }

    /// What the report records: None where no row depends on an unobserved parameter.
    pub fn report(&self) -> Option<UncheckedLines> {
        (!self.position.is_empty() || !self.orientation.is_empty()).then(|| UncheckedLines {
            unobserved: self.names.clone(),
            position_lines: self.position.clone(),
            orientation_lines: self.orientation.clone(),
        })
    }

    /// Warns (stderr) about the rows of `path` found: [`UncheckedRows::warning`].
    pub fn warn(&self, path: &Path, robot_path: &Path) {
        if let Some(w) = self.warning(path, robot_path) {
            eprintln!("warning: {w}");
        }
    }

    /// The warning on the rows of `path` found (a flag such as `--q`: the one pose it
    /// gave), naming `robot_path`'s unobserved parameters; None where none was found.
    pub fn warning(&self, path: &Path, robot_path: &Path) -> Option<String> {
        // One pose given on the command line (`--q`, `--pose`) has no lines to list.
        let single = path.to_str().is_some_and(|p| p.starts_with("--"));
        let mut parts = Vec::new();
        for (what, lines) in [
            ("position", &self.position),
            ("orientation", &self.orientation),
        ] {
            if lines.is_empty() {
                continue;
            }
            parts.push(if single {
                format!("the {what}")
            } else {
                format!(
                    "the {what} of {} row(s) (lines {})",
                    lines.len(),
                    robocal::data::measurement::list_lines(lines)
                )
            });
        }
        (!parts.is_empty()).then(|| {
            format!(
                "{}: {} {} on {} of {}, which its calibration did not observe (no effect on its \
                 measurements; they keep the start model's values): unchecked",
                path.display(),
                parts.join(" and "),
                if parts.len() > 1 { "depend" } else { "depends" },
                self.names.join(", "),
                robot_path.display()
            )
        })
    }
}
