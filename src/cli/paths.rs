//! Output paths checked against a command's inputs and against each other before anything is
//! read or written: calibration data is precious, and `--out` naming an input (or two outputs
//! naming one file) would silently destroy it.

use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// A path as the file system will resolve it: canonical when it exists, else its canonical
/// folder joined with its name (an output that does not exist yet). None when neither
/// resolves (the command's own read or write will report it).
fn resolved(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let name = p.file_name()?;
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(dir.canonicalize().ok()?.join(name))
}

/// "F does not exist" or "F is a file, not a folder" where a file cannot be written into the
/// folder `parent` (None for the current folder or a folder that is there).
fn unwritable_folder(parent: &Path) -> Option<String> {
    if parent.as_os_str().is_empty() || parent.is_dir() {
        return None;
    }
    let why = if parent.exists() {
        "is a file, not a folder"
    } else {
        "does not exist"
    };
    Some(format!("{} {why}", parent.display()))
}

/// A flag and its path; None for an optional path not given.
pub type Named<'a> = Option<(&'a str, &'a Path)>;

/// Refuses outputs that resolve to an input of the command or to another output, an output
/// file that is an existing folder or lies in a folder that does not exist, and a `--plot`
/// folder that is an existing file. Each
/// entry is a flag and its path ([`req`], [`opt`]).
pub fn guard(inputs: &[Named], outputs: &[Named]) -> Result<()> {
    let ins: Vec<(&str, &Path, PathBuf)> = inputs
        .iter()
        .flatten()
        .filter_map(|(f, p)| resolved(p).map(|r| (*f, *p, r)))
        .collect();
    let plots = || outputs.iter().flatten().filter(|(f, _)| *f == "--plot");
    // A `--plot` folder not there yet is made now (and removed again, empty, if the command
    // fails): an output file put in it then resolves and is checked as any other, and its
    // folder is there when it is written. An existing file is refused below.
    for (flag, dir) in plots() {
        if dir.is_symlink() && !dir.exists() {
            bail!(
                "{flag} {} is a link to nothing: give a folder, or link it to one",
                dir.display()
            );
        }
        if !dir.exists() {
            robocal::io::create_dir_all(dir)?;
        }
        // A folder under a name a picture may take is found now, not after the work (which
        // then stopped on "is a folder", without naming the flag).
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            if robocal::plot::may_draw(&entry.file_name().to_string_lossy())
                && entry.path().is_dir()
            {
                bail!(
                    "{flag} {}: {} is a folder, under a name its pictures may take ({}): \
                     remove it or choose another folder",
                    dir.display(),
                    entry.path().display(),
                    picture_names()
                );
            }
        }
    }
    // Where each output file lands, through its links (a link elsewhere to a picture's name
    // in a `--plot` folder clashes; a link in the folder to a file elsewhere does not).
    let outs: Vec<(&str, &Path, PathBuf)> = (outputs.iter().flatten())
        .filter(|(f, _)| *f != "--plot")
        .filter_map(|&(f, p)| Some((f, p, resolved(&robocal::io::output_file(p)?)?)))
        .collect();
    // A `--plot` folder's pictures and list (names the command chooses) must not land on an
    // input or another output: refused where such a file lies in the folder under a name
    // they could take.
    for (pf, dir) in plots() {
        let Some(dir_r) = resolved(dir) else { continue };
        let clash = ins.iter().chain(&outs).find(|(_, _, r)| {
            let name = r.file_name().and_then(|n| n.to_str()).unwrap_or("");
            robocal::plot::may_draw(name) && r.parent() == Some(dir_r.as_path())
        });
        if let Some((f, p, _)) = clash {
            usage!(
                "{f} {} lies in the {pf} folder {} under a name its pictures may take ({}): \
                 choose another folder or file name",
                p.display(),
                dir.display(),
                picture_names()
            );
        }
    }
    let mut seen: Vec<(&str, &Path, PathBuf)> = Vec::new();
    for (flag, path) in outputs.iter().flatten() {
        if robocal::io::is_standard_output(path) {
            super::SUMMARY_ON_STDERR.store(true, std::sync::atomic::Ordering::Relaxed);
        }
        // `--plot` names a folder of pictures; every other output is a file.
        let folder = *flag == "--plot";
        if folder && path.is_file() {
            bail!(
                "{flag} {} is a file: give a folder for the pictures",
                path.display()
            );
        }
        if !folder && path.is_dir() {
            bail!("{flag} {} is a folder: give a file path", path.display());
        }
        // Found now, not after the work: the file is written into an existing folder (a
        // `--plot` folder is made above), also through a link (the write had failed after
        // the work with "No such file or directory" alone).
        if !folder {
            if let Some(why) = path.parent().and_then(unwritable_folder) {
                bail!("{flag} {}: the folder {why}", path.display());
            }
            if let Some(target) = robocal::io::output_file(path)
                && target != *path
                && let Some(why) = target.parent().and_then(unwritable_folder)
            {
                bail!(
                    "{flag} {} is a link to {}, whose folder {why}",
                    path.display(),
                    target.display()
                );
            }
        }
        // Where the write lands, through its links (also to a file not there yet). None for
        // a device or a pipe (`/dev/null`, `/dev/stdout`), which takes every output given
        // it, or a loop of links, which the write reports.
        let Some(r) = robocal::io::output_file(path).and_then(|p| resolved(&p)) else {
            continue;
        };
        // Two flags at odds: a usage error (exit 2).
        if let Some((f, p, _)) = ins.iter().find(|(_, _, i)| *i == r) {
            usage!(
                "{flag} {} is the same file as an input ({f} {}): refusing to overwrite an input; \
                 choose another output path",
                path.display(),
                p.display()
            );
        }
        if let Some((f, p, _)) = seen.iter().find(|(_, _, o)| *o == r) {
            usage!(
                "{flag} {} and {f} {} name the same file: each output needs its own path",
                path.display(),
                p.display()
            );
        }
        seen.push((flag, path, r));
    }
    Ok(())
}

/// The names [`robocal::plot::may_draw`] takes, for messages: `case_d_*, ... .png or .svg,
/// figures.json`.
fn picture_names() -> String {
    let prefixes: Vec<String> = robocal::plot::COMMANDS
        .iter()
        .map(|c| format!("{c}_*"))
        .collect();
    format!(
        "{} .png or .svg, {}",
        prefixes.join(", "),
        robocal::plot::MANIFEST
    )
}

/// A required path for [`guard`]'s lists.
pub fn req<'a>(flag: &'a str, p: &'a Path) -> Named<'a> {
    Some((flag, p))
}

/// An optional path for [`guard`]'s lists.
pub fn opt<'a>(flag: &'a str, p: Option<&'a PathBuf>) -> Named<'a> {
    p.map(|p| (flag, p.as_path()))
}

/// Every file under `dir` (recursively): the inputs of commands that read a
/// folder (`report`, the datasets of `case-d` and `reproduce`).
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            match e.file_type() {
                Ok(t) if t.is_dir() => todo.push(p),
                Ok(_) => out.push(p),
                Err(_) => {}
            }
        }
    }
    out
}

/// The context of an error reading the shipped data sets under `datasets` for `what`: where
/// the shipped robot is not there, the hint to run from the repository root or give
/// `--datasets`; where it is, the error names its own file, and the context only says what
/// was being read.
pub fn datasets_context(datasets: &Path, what: &str) -> String {
    if datasets.join(robocal::studies::thesis::FANUC).exists() {
        format!("{what} from {}", datasets.display())
    } else {
        format!(
            "{}: no shipped data sets there (no {}): give --datasets the repository's \
             datasets folder, or run from the repository root",
            datasets.display(),
            robocal::studies::thesis::FANUC
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_file_by_another_spelling_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("data.csv");
        std::fs::write(&input, "x\n").unwrap();
        let other = dir.path().join("sub/../data.csv");
        std::fs::create_dir(dir.path().join("sub")).unwrap();
        let e = guard(&[req("--data", &input)], &[req("--out", &other)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--out") && e.contains("--data"), "{e}");
        // A new file beside it is fine; two outputs on one new file are not.
        let new = dir.path().join("new.csv");
        assert!(guard(&[req("--data", &input)], &[req("--out", &new)]).is_ok());
        assert!(guard(&[opt("--data", None)], &[req("--out", &input)]).is_ok());
        let e = guard(&[], &[req("--out-a", &new), req("--out-b", &new)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--out-a") && e.contains("--out-b"), "{e}");
        // A file in a folder that does not exist: refused before the work; a `--plot`
        // folder is made by the command.
        let lost = dir.path().join("no_such_folder/out.csv");
        let e = guard(&[], &[req("--out", &lost)]).unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        assert!(guard(&[], &[req("--plot", &dir.path().join("a/b"))]).is_ok());
        // A report inside the `--plot` folder the command makes is fine.
        let plots = dir.path().join("run");
        let report = plots.join("r.json");
        assert!(guard(&[], &[req("--plot", &plots), req("--report", &report)]).is_ok());
        // guard made the folder (outside a command, nothing removes it): without it, the
        // report's folder is missing.
        std::fs::remove_dir(&plots).unwrap();
        assert!(guard(&[], &[req("--report", &report)]).is_err());
        // A data file, an output or a report in the `--plot` folder under a picture's or
        // the list's name would be overwritten by them: refused (another name is fine).
        let svg = plots.join("evaluate_position.svg");
        std::fs::create_dir_all(&plots).unwrap();
        std::fs::write(&svg, "x\n").unwrap();
        let e = guard(&[req("--data", &svg)], &[req("--plot", &plots)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--data") && e.contains("--plot"), "{e}");
        let png = plots.join("identify_calibration_position.PNG");
        let e = guard(&[], &[req("--out", &png), req("--plot", &plots)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--out") && e.contains("pictures"), "{e}");
        let list = plots.join("figures.json");
        assert!(guard(&[], &[req("--report", &list), req("--plot", &plots)]).is_err());
        assert!(guard(&[], &[req("--report", &list)]).is_ok());
        assert!(
            guard(
                &[req("--data", &svg)],
                &[req("--plot", &dir.path().join("b"))]
            )
            .is_ok()
        );
        // Through links: an input whose link lies elsewhere, an output linked into the folder.
        #[cfg(unix)]
        {
            let link = dir.path().join("data_link.csv");
            std::os::unix::fs::symlink(&svg, &link).unwrap();
            assert!(guard(&[req("--data", &link)], &[req("--plot", &plots)]).is_err());
            let out = dir.path().join("rep.json");
            std::os::unix::fs::symlink(plots.join("FIGURES.JSON"), &out).unwrap();
            assert!(guard(&[], &[req("--report", &out), req("--plot", &plots)]).is_err());
        }
        // A device takes every output given it.
        #[cfg(unix)]
        {
            let null = Path::new("/dev/null");
            assert!(guard(&[], &[req("--out", null), req("--report", null)]).is_ok());
            // A link to a file not there yet and that file: one file.
            let (link, file) = (dir.path().join("link.csv"), dir.path().join("later.csv"));
            std::os::unix::fs::symlink("later.csv", &link).unwrap();
            let e = guard(&[], &[req("--out", &link), req("--report", &file)])
                .unwrap_err()
                .to_string();
            assert!(e.contains("name the same file"), "{e}");
            // A link to a file in a folder that does not exist (or is a file): refused before
            // the work, the flag and the link named.
            let dangling = dir.path().join("dangling.rcal");
            std::os::unix::fs::symlink("gone/x.rcal", &dangling).unwrap();
            let e = guard(&[], &[req("--out", &dangling)])
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("--out ")
                    && e.contains("is a link to")
                    && e.contains("gone/x.rcal, whose folder")
                    && e.ends_with("gone does not exist"),
                "{e}"
            );
            let into_file = dir.path().join("into_file.rcal");
            std::os::unix::fs::symlink("later.csv/x.rcal", &into_file).unwrap();
            std::fs::write(dir.path().join("later.csv"), "x\n").unwrap();
            let e = guard(&[], &[req("--report", &into_file)])
                .unwrap_err()
                .to_string();
            assert!(e.ends_with("is a file, not a folder"), "{e}");
            // A link to a file not there yet in a folder that is: fine.
            assert!(guard(&[], &[req("--out", &link)]).is_ok());
        }
        // A folder in the `--plot` folder under a picture's or the list's name: refused
        // before the work, naming the flag (upper case too).
        for name in ["identify_position.png", "Train_a.SVG", "figures.json"] {
            let plots = dir.path().join(format!("plots_{name}"));
            std::fs::create_dir_all(plots.join(name)).unwrap();
            let e = guard(&[], &[req("--plot", &plots)])
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("--plot ") && e.contains(&format!("{name} is a folder")),
                "{e}"
            );
            // A folder under another name is no picture's, nor one no command draws.
            std::fs::remove_dir(plots.join(name)).unwrap();
            std::fs::create_dir_all(plots.join("old_runs")).unwrap();
            std::fs::create_dir_all(plots.join("backup.png")).unwrap();
            assert!(guard(&[], &[req("--plot", &plots)]).is_ok());
        }
    }
}
