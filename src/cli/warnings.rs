//! The warnings a command prints, kept for its JSON report: what the terminal said is what
//! the file holds (a reviewer's `train` report had none of the warnings `train` printed).

/// Warnings in the order said; each printed on stderr as `warning: ...` when said.
#[derive(Debug, Default)]
pub struct Warnings(Vec<String>);

impl Warnings {
    /// Warnings printed already (a read's, which prints its own), kept for the report.
    pub fn printed(lines: Vec<String>) -> Warnings {
        Warnings(lines)
    }

    /// Adds warnings printed already (a read's).
    pub fn printed_too(&mut self, lines: Vec<String>) {
        self.0.extend(lines);
    }

    /// Prints `w` (without the `warning: ` prefix) and keeps it.
    pub fn say(&mut self, w: String) {
        eprintln!("warning: {w}");
        self.0.push(w);
    }

    /// [`Warnings::say`] where there is one.
    pub fn say_some(&mut self, w: Option<String>) {
        if let Some(w) = w {
            self.say(w);
        }
    }

    /// The warnings, in order, for a report.
    pub fn into_vec(self) -> Vec<String> {
        self.0
    }
}
