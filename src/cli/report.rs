//! `robocal report`: the HTML page of a run folder.

use anyhow::{Context, Result};
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
    let html = crate::report::render(&a.run_dir)?;
    crate::io::write_atomic(&a.out, html.as_bytes())
        .with_context(|| format!("writing {}", a.out.display()))?;
    println!("wrote {} ({} kB)", a.out.display(), html.len() / 1024);
    Ok(())
}
