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
    // A page under a report's or a picture's name would pass for one in a run folder (a
    // reviewer's `--out run/new.png` left HTML among the pictures).
    if let Some(e) = (a.out.extension().and_then(|e| e.to_str()))
        .filter(|e| ["json", "png", "svg"].contains(&e.to_ascii_lowercase().as_str()))
    {
        usage!(
            "--out {}: the page is HTML; a .{e} name would pass for a run folder's report or \
             picture (give an .html name)",
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
    Ok(())
}
