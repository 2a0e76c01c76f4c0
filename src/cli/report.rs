//! `robocal report`: the HTML page of a run folder.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ReportArgs {
    /// Run folder: JSON reports (--report) and pictures (--plot) of robocal commands.
    run_dir: PathBuf,
    /// HTML file to write (self-contained: pictures embedded). Written atomically.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: ReportArgs) -> Result<()> {
    use super::paths::{files_under, guard, req};
    // The page only ever goes to an .html name: under a report's or a picture's name it
    // would pass for one in a run folder (a reviewer's `--out run/new.png` left HTML among the
    // pictures), and under any other it could replace the run's own files, its robot, data or
    // compensator (a reviewer's `--out calibration.csv`, the data its identify report names,
    // was written over with HTML).
    let ext = (a.out.extension().and_then(|e| e.to_str())).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("html" | "htm")) {
        usage!(
            "--out {}: the page is HTML; give an .html (or .htm) name (only such a name is written, so \
             no report, picture, robot, data or compensator file is replaced by the page)",
            a.out.display()
        );
    }
    // What the page is made of: the folder's reports and pictures (a page written there
    // before is not read, so it may be written again).
    let read: Vec<_> = files_under(&a.run_dir)
        .into_iter()
        .filter(|p| {
            p.extension()
                .is_some_and(|e| e == "json" || e == "png" || e == "svg")
        })
        .collect();
    // And every picture its figure list names, whatever its name (a list the page cannot
    // read is refused by the page).
    let listed: Vec<PathBuf> = (robocal::plot::read_manifest(&a.run_dir).unwrap_or_default())
        .iter()
        .flat_map(|f| [&f.png, &f.svg])
        .map(|name| a.run_dir.join(name))
        .collect();
    let inputs: Vec<_> = (read.iter().chain(&listed))
        .map(|p| req("run folder", p))
        .collect();
    guard(&inputs, &[req("--out", &a.out)])?;
    let html = robocal::reports::html::render(&a.run_dir)?;
    super::output::writing(robocal::io::write_atomic(&a.out, html.as_bytes()), &a.out)?;
    told_after!("wrote {} ({} kB)", a.out.display(), html.len() / 1024);
    // Pictures copied into the folder without their list: left out of the page, by name.
    let unlisted = robocal::reports::html::unlisted_pictures(&a.run_dir)?;
    if !unlisted.is_empty() {
        eprintln!(
            "warning: {}: {} picture(s) that {} does not list are not on the page: {} (an \
             earlier run's, which a later run of the same command there took off the list, or \
             pictures copied in without it; the page shows the listed pictures, with the \
             titles and captions the list gives)",
            a.run_dir.display(),
            unlisted.len(),
            robocal::plot::MANIFEST,
            robocal::data::measurement::list_lines(&unlisted)
        );
    }
    Ok(())
}
