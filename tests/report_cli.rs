//! `--plot` pictures and `robocal report`: the page is self-contained and a real browser
//! (headless Chromium, installed by .ci/run) shows its tables and pictures.

mod common;
use common::{identify_case_d, robocal, stderr, tmp};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A run folder with an identify report and its pictures.
fn run_dir(name: &str) -> PathBuf {
    let dir = tmp(name);
    std::fs::create_dir_all(&dir).unwrap();
    let out = identify_case_d(
        &dir.join("robot.toml"),
        &[
            "--validate",
            "datasets/case_d/test_truth.csv",
            "--report",
            dir.join("identify.json").to_str().unwrap(),
            "--plot",
            dir.to_str().unwrap(),
        ],
    );
    assert!(out.contains("plots: 8 pictures"), "{out}");
    dir
}

fn figures(dir: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("figures.json")).unwrap();
    serde_json::from_str::<serde_json::Value>(&text)
        .unwrap()
        .as_array()
        .unwrap()
        .clone()
}

#[test]
fn plots_are_png_and_svg_with_axis_titles() {
    let dir = run_dir("plots");
    let figs = figures(&dir);
    let names: Vec<&str> = figs.iter().map(|f| f["png"].as_str().unwrap()).collect();
    for want in [
        "identify_calibration_position.png",
        "identify_calibration_orientation.png",
        "identify_calibration_histogram.png",
        "identify_calibration_scatter.png",
        "identify_validation_position.png",
    ] {
        assert!(names.contains(&want), "{names:?}");
    }
    for f in &figs {
        let png = image::open(dir.join(f["png"].as_str().unwrap()))
            .unwrap()
            .to_rgb8();
        assert_eq!(png.dimensions(), (1100, 600));
        // Not blank: dark text and coloured data cover a real part of the picture.
        let inked = png
            .pixels()
            .filter(|p| p.0.iter().any(|c| *c < 200))
            .count();
        assert!(
            inked > 1100 * 600 / 100,
            "{}: {inked} inked pixels",
            f["png"]
        );
        let svg = std::fs::read_to_string(dir.join(f["svg"].as_str().unwrap())).unwrap();
        assert!(svg.starts_with("<svg"), "{}", f["svg"]);
        assert!(!f["title"].as_str().unwrap().is_empty());
    }
    let svg = std::fs::read_to_string(dir.join("identify_calibration_position.svg")).unwrap();
    assert!(svg.contains("position error (mm)") && svg.contains("line in the data file"));
    assert!(svg.contains("identified: mean"), "legend with means");
    // Distance data: one length error per pair, titled so (they were position errors per
    // measurement, a helper's).
    let pairs = tmp("plots_pairs");
    std::fs::create_dir_all(&pairs).unwrap();
    let out = identify_case_d(
        &pairs.join("robot.toml"),
        &["--measure", "distance", "--plot", pairs.to_str().unwrap()],
    );
    assert!(out.contains("plots:"), "{out}");
    let titles: Vec<String> = (figures(&pairs).iter())
        .map(|f| f["title"].as_str().unwrap().to_string())
        .collect();
    assert!(
        titles.contains(&"Length error per pair, calibration data".to_string())
            && !titles.iter().any(|t| t.contains("Position error")),
        "{titles:?}"
    );
}

/// The Chromium to run: `ROBOCAL_CHROMIUM`, else the first of the usual names on PATH, else
/// Debian's package installed here (as root, or through password-less sudo), said on stderr:
/// the README's test command needs no manual step on a fresh Debian machine.
fn chromium_exe() -> String {
    static EXE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    EXE.get_or_init(|| {
        if let Ok(e) = std::env::var("ROBOCAL_CHROMIUM") {
            return e;
        }
        let names = ["chromium", "chromium-browser", "google-chrome"];
        let found = |n: &&str| {
            Command::new(n)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        };
        if let Some(n) = names.iter().find(|n| found(n)) {
            return n.to_string();
        }
        eprintln!(
            "report test: no Chromium on PATH; installing Debian's chromium (apt-get) for the \
             headless rendering test"
        );
        let root = Command::new("id")
            .arg("-u")
            .output()
            .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
        let apt = |args: &[&str]| {
            let mut c = if root {
                Command::new("apt-get")
            } else {
                let mut c = Command::new("sudo");
                c.args(["-n", "apt-get"]);
                c
            };
            c.args(args)
                .env("DEBIAN_FRONTEND", "noninteractive")
                .output()
                .is_ok_and(|o| o.status.success())
        };
        let installed = apt(&["update", "-qq"]) && apt(&["install", "-y", "-qq", "chromium"]);
        if !installed {
            panic!(
                "no Chromium, and installing Debian's chromium failed (not root, no \
                 password-less sudo, or no apt-get): install chromium or set ROBOCAL_CHROMIUM"
            );
        }
        "chromium".into()
    })
    .clone()
}

/// Headless Chromium: DOM after load, and a screenshot.
fn chromium(page: &Path, shot: &Path) -> String {
    let exe = chromium_exe();
    let profile = tmp("chromium-profile");
    let common = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--window-size=1280,4000",
    ];
    let url = format!("file://{}", page.canonicalize().unwrap().display());
    let run = |extra: &[String]| {
        Command::new(&exe)
            .args(common)
            .arg(format!("--user-data-dir={}", profile.display()))
            .args(extra)
            .arg(&url)
            .output()
            .unwrap_or_else(|e| {
                panic!("{exe}: {e}; install Debian's chromium or set ROBOCAL_CHROMIUM")
            })
    };
    let o = run(&[format!("--screenshot={}", shot.display())]);
    assert!(
        shot.exists(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let o = run(&["--dump-dom".into()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn report_page_shows_tables_and_pictures_in_a_browser() {
    let dir = run_dir("report_run");
    let page = dir.join("report.html");
    let o = robocal(&[
        "report",
        dir.to_str().unwrap(),
        "--out",
        page.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(&page).unwrap();
    // Self-contained: every picture embedded, nothing fetched.
    let n = figures(&dir).len();
    assert_eq!(html.matches("<img src=\"data:image/png;base64,").count(), n);
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));

    let shot = tmp("report.png");
    let dom = chromium(&page, &shot);
    assert_eq!(dom.matches("<figure>").count(), n, "figures in the DOM");
    assert!(dom.matches("<table").count() >= 3, "tables in the DOM");
    for want in [
        "Accuracy",
        "calibration",
        "validation",
        "condition_number_all_candidates",
        "base.x",
        "condition_number",
    ] {
        assert!(dom.contains(want), "{want} not in the DOM");
    }
    // The screenshot is not blank and shows the plots' series colours (so the embedded
    // pictures were decoded and drawn, not just the text).
    let img = image::open(&shot).unwrap().to_rgb8();
    let total = (img.width() * img.height()) as usize;
    let inked = img
        .pixels()
        .filter(|p| p.0.iter().any(|c| *c < 200))
        .count();
    assert!(inked * 50 > total, "{inked} of {total} pixels inked");
    let near = |p: &image::Rgb<u8>, c: [u8; 3]| {
        p.0.iter()
            .zip(c)
            .all(|(a, b)| (*a as i32 - b as i32).abs() < 12)
    };
    for colour in [[214, 39, 40], [31, 119, 180]] {
        let k = img.pixels().filter(|p| near(p, colour)).count();
        assert!(k > 200, "{k} pixels of colour {colour:?}");
    }
}

#[test]
fn report_refuses_empty_folders_and_bad_json() {
    let empty = tmp("empty_run");
    std::fs::create_dir_all(&empty).unwrap();
    let out = tmp("never.html");
    let o = robocal(&[
        "report",
        empty.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no reports"), "{}", stderr(&o));
    std::fs::write(empty.join("broken.json"), "{\n  \"a\": 1,\n  oops\n}\n").unwrap();
    let o = robocal(&[
        "report",
        empty.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("broken.json:3:"), "{}", stderr(&o));
    assert!(!out.exists());
    // A page under any name but .html (a picture's, a report's, the run's data, robot or
    // compensator): refused before any work (usage, 2), an existing file untouched.
    std::fs::write(empty.join("calibration.csv"), "q1\n1\n").unwrap();
    for name in [
        "new.png",
        "new.SVG",
        "new.json",
        "calibration.csv",
        "cal.toml",
        "comp.rcal",
        "page",
    ] {
        let out = empty.join(name);
        let before = std::fs::read(&out).ok();
        let o = robocal(&[
            "report",
            empty.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("give an .html (or .htm) name"),
            "{}",
            stderr(&o)
        );
        assert_eq!(std::fs::read(&out).ok(), before, "{name}");
    }
}

/// `report` embeds only regular files inside the run folder, of bounded size: a figure list
/// naming `/etc/hostname` or `../x.png`, a link to `/dev/zero` among the pictures or the
/// reports, are refused by name (before: embedded, or read until memory ran out).
#[cfg(unix)]
#[test]
fn report_embeds_only_files_inside_the_run_folder() {
    let dir = tempfile::Builder::new().prefix("run").tempdir().unwrap();
    let run = dir.path().join("run");
    std::fs::create_dir(&run).unwrap();
    std::fs::write(dir.path().join("x.png"), "outside").unwrap();
    let out = dir.path().join("page.html");
    let list = |png: &str| {
        format!(
            "[{{\"png\": \"{png}\", \"svg\": \"a.svg\", \"title\": \"t\", \"caption\": \"c\"}}]"
        )
    };
    let page = || {
        robocal(&[
            "report",
            run.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    std::os::unix::fs::symlink("/dev/zero", run.join("zero.png")).unwrap();
    for (png, want) in [
        ("/etc/hostname", "outside the run folder"),
        ("../x.png", "outside the run folder"),
        ("zero.png", "outside the run folder"),
    ] {
        std::fs::write(run.join("figures.json"), list(png)).unwrap();
        let o = page();
        assert_eq!(o.status.code(), Some(1), "{png}");
        assert!(stderr(&o).contains(want), "{png}: {}", stderr(&o));
        assert!(!out.exists());
    }
    // A picture the list names, whatever its name, is an input: not overwritten by --out.
    std::fs::write(run.join("figures.json"), list("page.html")).unwrap();
    std::fs::write(run.join("page.html"), "a picture").unwrap();
    let inside = run.join("page.html");
    let o = robocal(&[
        "report",
        run.to_str().unwrap(),
        "--out",
        inside.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("refusing to overwrite an input"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read_to_string(&inside).unwrap(), "a picture");
    std::fs::remove_file(&inside).unwrap();
    std::fs::remove_file(run.join("figures.json")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", run.join("zero.json")).unwrap();
    let o = page();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("zero.json: not a regular file"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

#[test]
fn a_second_run_into_a_plot_folder_replaces_the_listing_of_the_first() {
    // identify with validation rows (8 pictures), then without them into the same folder:
    // the list holds the second run's 4 identify pictures, not the first run's validation
    // ones beside them; another command's pictures stay listed.
    let dir = run_dir("plots_twice");
    let comp = dir.join("net.rcal");
    let o = common::train_fanuc(
        "datasets/case_d/training.csv",
        comp.to_str().unwrap(),
        &[common::CHEAP_TRAIN, &["--plot", dir.to_str().unwrap()]].concat(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let trained = figures(&dir).len() - 8;
    assert!(trained > 0);
    // Nothing held out (--validation-fraction 0): the curve beside the training MSE is the
    // penalised objective, not a validation error (it was labelled so, a helper's).
    let svg = std::fs::read_to_string(dir.join("train_training.svg")).unwrap();
    assert!(
        svg.contains("penalised objective") && !svg.contains(">validation"),
        "{svg}"
    );
    let out = identify_case_d(&dir.join("robot2.toml"), &["--plot", dir.to_str().unwrap()]);
    assert!(out.contains("plots: 4 pictures"), "{out}");
    let figs = figures(&dir);
    let png = |f: &serde_json::Value| f["png"].as_str().unwrap().to_string();
    let identify: Vec<String> = (figs.iter().map(png))
        .filter(|p| p.starts_with("identify_"))
        .collect();
    assert_eq!(identify.len(), 4, "{identify:?}");
    assert!(
        identify.iter().all(|p| !p.contains("validation")),
        "{identify:?}"
    );
    assert_eq!(figs.len(), 4 + trained, "{figs:?}");
}

/// A listed picture that is not a whole PNG (empty, cut short, text) is refused by name: a
/// browser showed a broken picture and `report` said nothing (a reviewer's run folder).
#[test]
fn report_refuses_pictures_that_are_not_whole_pngs() {
    let dir = run_dir("report_broken_png");
    let name = "identify_calibration_position.png";
    let png = std::fs::read(dir.join(name)).unwrap();
    let page = dir.join("broken.html");
    for (what, bytes) in [
        ("empty", Vec::new()),
        ("cut", png[..png.len() / 2].to_vec()),
        ("text", b"hello".to_vec()),
    ] {
        std::fs::write(dir.join(name), &bytes).unwrap();
        let o = robocal(&[
            "report",
            dir.to_str().unwrap(),
            "--out",
            page.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(1), "{what}");
        let e = stderr(&o);
        assert!(
            e.contains(name) && e.contains("not a whole PNG picture"),
            "{what}: {e}"
        );
        assert!(!page.exists(), "{what}");
    }
    std::fs::write(dir.join(name), &png).unwrap();
    let o = robocal(&[
        "report",
        dir.to_str().unwrap(),
        "--out",
        page.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Pictures copied into a run folder without the figure list that names them (or beside it)
/// are not on the page, which shows a picture with the title and caption its list gives:
/// `report` names them in a warning (it had said "0 figure(s)" and nothing else).
#[test]
fn report_names_the_pictures_its_list_leaves_out() {
    let dir = run_dir("unlisted");
    let page = dir.join("page.html");
    let report = || {
        robocal(&[
            "report",
            dir.to_str().unwrap(),
            "--out",
            page.to_str().unwrap(),
        ])
    };
    let o = report();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("does not list"), "{}", stderr(&o));
    let png = dir.join("identify_calibration_position.png");
    std::fs::copy(&png, dir.join("extra.png")).unwrap();
    std::fs::copy(&png, dir.join("old.SVG")).unwrap();
    let o = report();
    assert!(o.status.success(), "{}", stderr(&o));
    let said =
        "2 picture(s) that figures.json does not list are not on the page: extra.png, old.SVG (";
    assert!(stderr(&o).contains(said), "{}", stderr(&o));
    // Without the list, every picture is named, a picture's PNG and SVG as one (8 drawn,
    // and the two copies; the report is still shown).
    std::fs::remove_file(dir.join("figures.json")).unwrap();
    let o = report();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("10 picture(s) that figures.json does not list")
            && stderr(&o).contains("identify_validation_position.png/.svg,"),
        "{}",
        stderr(&o)
    );
}
