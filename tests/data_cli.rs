//! `robocal import` and `robocal simulate` from the command line: every bad-input kind gives its
//! error (file, line, column) and exit code; warnings keep exit code 0.

mod common;
use common::{FANUC, robocal, stderr, tmp};

const HEADER: &str = "id,q1,q2,q3,q4,q5,q6,x,y,z\n";

/// Runs `import` of `body` (after the canonical header) and returns (exit code, stderr, out).
fn import(name: &str, body: &str, extra: &[&str]) -> (i32, String, Option<String>) {
    let input = tmp(&format!("{name}.csv"));
    std::fs::write(&input, format!("{HEADER}{body}")).unwrap();
    let out = tmp(&format!("{name}.out.csv"));
    let _ = std::fs::remove_file(&out);
    let mut args = vec![
        "import",
        input.to_str().unwrap(),
        "--robot",
        FANUC,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = robocal(&args);
    (
        o.status.code().unwrap_or(-1),
        stderr(&o),
        std::fs::read_to_string(&out).ok(),
    )
}

// Positions near the FANUC's own at those joints (mm): a file in metres gets a warning.
const GOOD: &str = "a,0,0,0,0,0,0,2032,-182,1970\nb,10,10,10,10,10,10,2215.8,203.5,1940.2\nc,20,20,20,20,20,20,2315.8,638.4,1877.2\n";

#[test]
fn good_file_imports_silently() {
    let (code, err, out) = import("good", GOOD, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("warning"), "{err}");
    assert!(
        out.unwrap()
            .starts_with("id,q1,q2,q3,q4,q5,q6,x,y,z\na,0,0,0,0,0,0,2032,-182,1970\n")
    );
    // The same positions in metres: written as read, with the warning `identify` would
    // turn into an error.
    let metres = GOOD
        .lines()
        .map(|l| {
            let mut c: Vec<String> = l.split(',').map(str::to_string).collect();
            for v in &mut c[7..] {
                *v = format!("{}", v.parse::<f64>().unwrap() / 1000.0);
            }
            c.join(",") + "\n"
        })
        .collect::<String>();
    let (code, err, out) = import("good_metres", &metres, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("0.0010 times as far (positions in metres give 0.001")
            && err.contains("(written as read: `identify` and `train` refuse such rows)"),
        "{err}"
    );
    assert!(out.unwrap().contains("a,0,0,0,0,0,0,2.032,-0.182,1.97\n"));
}

#[test]
fn each_bad_input_kind_gives_its_error() {
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "count",
            "a,0,0,0,0,0,0,1,2\n",
            &[":5", "9 cells", "10 columns"],
        ),
        (
            "parse",
            "a,0,0,zero,0,0,0,1,2,3\n",
            &[":5", "q3", "`zero` is not a number"],
        ),
        ("nan", "a,0,0,0,0,0,0,1,NaN,3\n", &[":5", "y", "not finite"]),
        ("inf", "a,0,0,0,0,0,0,1,2,inf\n", &[":5", "z", "not finite"]),
    ];
    for (name, body, needles) in cases {
        // Three good rows (lines 2-4), then the bad one on line 5.
        let (code, err, out) = import(name, &format!("{GOOD}{body}"), &[]);
        assert_eq!(code, 1, "{name}: {err}");
        for n in *needles {
            assert!(err.contains(n), "{name}: `{n}` not in {err}");
        }
        assert!(out.is_none(), "{name}: no output file on error");
    }
}

#[test]
fn line_numbers_count_every_line() {
    let (code, err, _) = import("lines", "a,0,0,0,0,0,0,1,2,3\n\nb,0,0,0,0,0,0,1,2,x\n", &[]);
    assert_eq!(code, 1);
    assert!(err.contains("lines.csv:4") && err.contains("`x`"), "{err}");
}

/// Several empty orientation cells: the error names the first in the file (rz), not the last
/// read (rx: the angles are read about x, y, z).
#[test]
fn the_first_bad_cell_of_a_row_is_named() {
    let text = "id,q1,q2,q3,q4,q5,q6,x,y,z,rz,ry,rx\na,0,0,0,0,0,0,2032,-182,1970,0,90,0\n\
                b,0,0,0,0,0,0,2032,-182,1970,,,\nc,0,0,0,0,0,0,2032,-182,1970,0,,x\n";
    let (o, _) = import_text("first_bad_cell", text, &[]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(err.contains(":3: field `rz`"), "{err}");
    let text = text.replace("b,0,0,0,0,0,0,2032,-182,1970,,,\n", "");
    let (o, _) = import_text("first_bad_cell", &text, &[]);
    let err = stderr(&o);
    assert!(err.contains(":3: field `ry`"), "{err}");
}

/// Imports a whole file text (header included) written as `name`.csv, with `extra` flags,
/// into `name`.out: the run and the output's path.
fn import_text(
    name: &str,
    text: &str,
    extra: &[&str],
) -> (std::process::Output, std::path::PathBuf) {
    let input = tmp(&format!("{name}.csv"));
    std::fs::write(&input, text).unwrap();
    let out = tmp(&format!("{name}.out"));
    let mut args = vec![
        "import",
        input.to_str().unwrap(),
        "--robot",
        FANUC,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    (robocal(&args), out)
}

/// Imports a whole file text (header included) and expects exit code 1 with `needles` in the
/// message.
fn import_fails(name: &str, text: &str, needles: &[&str]) {
    let (o, out) = import_text(name, text, &[]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    for n in needles {
        assert!(err.contains(n), "`{n}` not in {err}");
    }
    assert!(!out.exists());
}

/// A column the header holds in capitals is named so (names are case-sensitive), beside the
/// header's list.
#[test]
fn a_column_in_other_case_is_said_to_differ_only_in_case() {
    import_fails(
        "case",
        "q1,q2,q3,q4,q5,q6,X,y,z\n0,0,0,0,0,0,1,2,3\n",
        &[
            "case.csv:1: field `x`: position columns must come as a group of three; missing \
             column(s); X differs only in case (column names are case-sensitive)",
        ],
    );
    import_fails(
        "case_q",
        "Q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,0,1,2,3\n",
        &[
            "case_q.csv:1: field `q1`: missing column (the header has: Q1, q2",
            "; Q1 differs only in case (column names are case-sensitive)",
        ],
    );
    import_fails(
        "case_xyz",
        "q1,q2,q3,q4,q5,q6,X,Y,Z\n0,0,0,0,0,0,1,2,3\n",
        &["no measurement columns", "; Z differs only in case"],
    );
    // An optional group in other case beside one that reads: it had been left out without a
    // word (a reviewer's X, Y, Z beside angles identified from orientations alone; SX, SY, SZ
    // left the default sigmas; a `Pair` column chained the rows in file order).
    for (name, header, needle) in [
        (
            "case_pos",
            "q1,q2,q3,q4,q5,q6,X,Y,Z,rz,ry,rx",
            "case_pos.csv:1: field `x, y, z`: no position column(s) x, y, z, but the header \
             has X for x, Y for y, Z for z: column names are case-sensitive",
        ),
        (
            "case_rot",
            "q1,q2,q3,q4,q5,q6,x,y,z,RZ,RY,RX",
            "no orientation column(s) rx, ry, rz, but the header has RX for rx",
        ),
        (
            "case_sigma",
            "q1,q2,q3,q4,q5,q6,x,y,z,SX,SY,SZ",
            "no position sigma column(s) sx, sy, sz",
        ),
    ] {
        let cells = header.split(',').count();
        let row = vec!["1"; cells].join(",");
        import_fails(name, &format!("{header}\n{row}\n"), &[needle]);
    }
    // Groups that would not be read stay carried columns: a quaternion under the default
    // (Euler) profile, orientation sigmas beside positions alone, a `Set` label, and a `Pair`
    // or `Distance` column, which counts only under the pair measures (refused there, below).
    for name in [
        "case_quat",
        "case_srx",
        "case_set",
        "case_pair",
        "case_distance",
    ] {
        let header = match name {
            "case_quat" => "q1,q2,q3,q4,q5,q6,x,y,z,QW,QX,QY,QZ",
            "case_srx" => "q1,q2,q3,q4,q5,q6,x,y,z,SRX,SRY,SRZ",
            "case_set" => "q1,q2,q3,q4,q5,q6,x,y,z,Set",
            "case_pair" => "q1,q2,q3,q4,q5,q6,x,y,z,Pair",
            _ => "q1,q2,q3,q4,q5,q6,x,y,z,Distance",
        };
        let cells = header.split(',').count();
        let row = vec!["1"; cells].join(",");
        let (o, _) = import_text(name, &format!("{header}\n{row}\n"), &[]);
        let err = stderr(&o);
        assert!(o.status.success(), "{name}: {err}");
        assert!(!err.contains("case-sensitive"), "{name}: {err}");
    }
}

/// A `Pair` or `Distance` column in other letter case is refused by the measures that read
/// it (read as absent, it had left the pairs chained in file order and the distances found
/// from the positions), in `identify` and `evaluate`: a pair label by both pair measures, a
/// distance by `distance` alone; the other measures read the file.
#[test]
fn a_pair_column_in_other_case_is_refused_by_the_measures_that_read_it() {
    let rows = "0,0,0,0,0,0,2032,-182,1970,a,1\n10,10,10,10,10,10,2215.8,203.5,1940.2,a,2\n\
                20,20,20,20,20,20,2315.8,638.4,1877.2,b,3\n0,10,0,10,0,10,2000,0,1900,b,4\n";
    let pair = "reads the label of each row's pair from a `pair` column, but the header has \
                `Pair`: column names are case-sensitive, so it would be read as absent, and the \
                pairs chained in file order; rename it `pair`";
    let distance = "reads each pair's distance from a `distance` column, but the header has \
                    `DISTANCE`: column names are case-sensitive, so it would be read as absent, \
                    and the distances found from the positions";
    for (header, name, relative, by_distance) in [
        (
            "q1,q2,q3,q4,q5,q6,x,y,z,Pair,distance",
            "pair",
            Some(pair),
            pair,
        ),
        (
            "q1,q2,q3,q4,q5,q6,x,y,z,pair,DISTANCE",
            "distance",
            None,
            distance,
        ),
    ] {
        let data = tmp(&format!("case_{name}_column.csv"));
        std::fs::write(&data, format!("{header}\n{rows}")).unwrap();
        let out = tmp("case_pair_out.toml");
        let d = data.to_str().unwrap();
        for (measure, says) in [("relative", relative), ("distance", Some(by_distance))] {
            for cmd in ["identify", "evaluate"] {
                let mut args = vec![cmd, "--robot", FANUC, "--data", d, "--measure", measure];
                if cmd == "identify" {
                    args.extend(["--out", out.to_str().unwrap()]);
                }
                let o = robocal(&args);
                let err = stderr(&o);
                match says {
                    Some(says) => {
                        assert_eq!(o.status.code(), Some(1), "{cmd} {measure} {name}: {err}");
                        assert!(
                            err.contains(&format!("measuring by {measure} {says}")),
                            "{cmd} {measure} {name}: {err}"
                        );
                    }
                    // Relative reads no distance: the file is read (`evaluate` runs).
                    None => assert!(
                        !err.contains("case-sensitive")
                            && (cmd == "identify" || o.status.success()),
                        "{cmd} {measure} {name}: {err}"
                    ),
                }
            }
        }
        let o = robocal(&[
            "evaluate",
            "--robot",
            FANUC,
            "--data",
            d,
            "--measure",
            "position",
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
}

/// A column a profile names for a label or a distance that the file lacks is an error, as a
/// position's is: a typo had left the distances computed from positions without a word.
#[test]
fn a_label_or_distance_column_the_profile_names_must_be_there() {
    let text = "q1,q2,q3,q4,q5,q6,x,y,z,ballbar\n0,0,0,0,0,0,1,2,3,4\n";
    for (key, name) in [
        ("distance", "ball_bar"),
        ("pair", "pairs"),
        ("set", "group"),
        ("id", "label"),
    ] {
        let profile = tmp(&format!("p_{key}.toml"));
        std::fs::write(&profile, format!("[columns]\n{key} = \"{name}\"\n")).unwrap();
        let (o, out) = import_text(
            &format!("labels_{key}"),
            text,
            &["--profile", profile.to_str().unwrap()],
        );
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{key}: {err}");
        assert!(
            err.contains(&format!(
                "p_{key}.toml: the profile reads the {key} from column `{name}`, which"
            )) && err.contains(&format!("labels_{key}.csv does not have (its columns: q1")),
            "{key}: {err}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn duplicate_header_is_an_error() {
    import_fails(
        "dup",
        "q1,q2,q3,q4,q5,q6,x,y,z,x\n0,0,0,0,0,0,1,2,3,4\n",
        &["dup.csv:1", "duplicate"],
    );
}

#[test]
fn joints_outside_limits_warn_or_fail_with_strict() {
    // J2 is limited to -50..70 deg: 80 is outside (line 3).
    let body = "a,0,0,0,0,0,0,1,2,3\nb,0,80,0,0,0,0,1,2,3\n";
    let (code, err, out) = import("limits", body, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("outside the robot's limits (lines 3)"),
        "{err}"
    );
    assert!(out.is_some());
    let (code, err, out) = import("limits_strict", body, &["--strict"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("limits_strict.csv") && err.contains("lines 3"),
        "{err}"
    );
    assert!(out.is_none());
}

#[test]
fn radians_in_a_degree_file_warn() {
    let body = "a,0.1,0.2,-0.3,1.5,-1.2,3.1\n".replace(",3.1\n", ",3.1,1,2,3\n");
    let body = format!("{body}{body}{body}");
    let (code, err, _) = import("radians", &body, &[]);
    assert_eq!(code, 0);
    assert!(err.contains("are they radians"), "{err}");
}

/// A joint of +-400 deg holds radians up to 6.98: a radian file with a value beyond 6.3 in
/// it was read as degrees without a word (a helper's finding on an ABB IRB 140). The
/// warning now takes each joint's range in radians where it is wider than 6.3, for `import`,
/// for joint files (`fk`, and `plan --evaluate`, `--candidates`), for the seed columns of
/// target files (`ik`, `compensate`) and for `--seed` and `--q` on the command line; degrees
/// stay quiet.
#[test]
fn radians_of_a_joint_wider_than_a_turn_warn() {
    let fanuc = std::fs::read_to_string(common::root().join(FANUC)).unwrap();
    let last = fanuc.rfind("limits = [-180.0, 180.0]").unwrap();
    let wide = format!(
        "{}limits = [-400.0, 400.0]{}",
        &fanuc[..last],
        &fanuc[last + "limits = [-180.0, 180.0]".len()..]
    );
    let robot = tmp("wide_j6.toml");
    std::fs::write(&robot, wide).unwrap();
    let robot = robot.to_str().unwrap();
    let radians =
        "0.1,0.2,-0.3,1.5,-1.2,6.5\n0.2,0.1,-0.2,1.0,-1.0,-6.7\n0.3,0.3,0.1,-1.0,1.1,2.0\n";
    let degrees = "10,20,-30,150,-12,350\n20,10,-20,100,-10,-370\n30,30,10,-100,11,200\n";
    for (body, warns) in [(radians, true), (degrees, false)] {
        let joints = tmp(&format!("wide_{warns}.csv"));
        std::fs::write(&joints, format!("q1,q2,q3,q4,q5,q6\n{body}")).unwrap();
        let out = tmp(&format!("wide_{warns}.out.csv"));
        let o = robocal(&[
            "fk",
            "--robot",
            robot,
            "--joints",
            joints.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            stderr(&o).contains("one turn in radians"),
            warns,
            "{}",
            stderr(&o)
        );
        let rows: String = body.lines().map(|l| format!("{l},1,2,3\n")).collect();
        let data = tmp(&format!("wide_{warns}_data.csv"));
        std::fs::write(&data, format!("q1,q2,q3,q4,q5,q6,x,y,z\n{rows}")).unwrap();
        let out = tmp(&format!("wide_{warns}_data.out.csv"));
        let o = robocal(&[
            "import",
            data.to_str().unwrap(),
            "--robot",
            robot,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            stderr(&o).contains("are they radians"),
            warns,
            "{}",
            stderr(&o)
        );
        // Seed columns of a target file, for `ik` and `compensate` (a seed read as degrees
        // picks another configuration, or none within the limits).
        let rows: String = body
            .lines()
            .map(|l| format!("1842,0,1652,0,90,0,{l}\n"))
            .collect();
        let targets = tmp(&format!("wide_{warns}_targets.csv"));
        std::fs::write(
            &targets,
            format!("x,y,z,rz,ry,rx,q1,q2,q3,q4,q5,q6\n{rows}"),
        )
        .unwrap();
        let t = targets.to_str().unwrap();
        let compensate = [
            "compensate",
            "--nominal",
            FANUC,
            "--robot",
            robot,
            "--targets",
            t,
        ];
        // The last row as --seed or --q on the command line (the first's 6.5 is no radian
        // for the nominal FANUC's +-180 deg, which `compensate --seed` reads with; the
        // degrees given a fraction, as whole numbers are taken for degrees anyway), and the
        // file as the configurations `plan` evaluates or chooses from: the same rule (they
        // went without a word). Both plans then fail for too few units, after the warning.
        let last = if warns {
            body.lines().last().unwrap()
        } else {
            "30.5,30,10,-100,11,200"
        };
        let j = joints.to_str().unwrap();
        let planned = tmp(&format!("wide_{warns}_planned.csv"));
        let planned = planned.to_str().unwrap();
        let pose = ["--pose", "1842,0,1652,0,90,0", "--seed", last];
        let (seed_columns, joints_said) = (
            "every seed joint angle lies within +-6.28",
            "every joint angle lies within +-6.28, one turn in radians",
        );
        for (args, said) in [
            (vec!["ik", "--robot", robot, "--poses", t], seed_columns),
            (compensate.to_vec(), seed_columns),
            ([&["ik", "--robot", robot][..], &pose].concat(), joints_said),
            ([&compensate[..], &pose[2..]].concat(), joints_said),
            (vec!["fk", "--robot", robot, "--q", last], joints_said),
            (
                vec![
                    "plan",
                    "--robot",
                    robot,
                    "--evaluate",
                    j,
                    "--validation",
                    "20",
                ],
                joints_said,
            ),
            (
                vec![
                    "plan",
                    "--robot",
                    robot,
                    "--candidates",
                    j,
                    "--count",
                    "2",
                    "--out",
                    planned,
                ],
                joints_said,
            ),
        ] {
            let o = robocal(&args);
            assert_eq!(stderr(&o).contains(said), warns, "{args:?}: {}", stderr(&o));
        }
    }
}

#[test]
fn skip_bad_rows_drops_and_lists_them() {
    let body =
        "a,0,0,0,0,0,0,1,2,3\nb,0,0,oops,0,0,0,1,2,3\nc,0,0,0,0,0,0,1,2\nd,1,1,1,1,1,1,1,2,3\n";
    let (code, err, out) = import("skip", body, &["--skip-bad-rows"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("dropped 2 bad row(s) (lines 3, 4)"), "{err}");
    let out = out.unwrap();
    assert_eq!(out.lines().count(), 3, "{out}");
    assert!(out.contains("\na,") && out.contains("\nd,"));
}

#[test]
fn missing_position_group_member_is_an_error() {
    import_fails(
        "group",
        "q1,q2,q3,q4,q5,q6,x,y\n0,0,0,0,0,0,1,2\n",
        &["group.csv:1", "`z`"],
    );
}

#[test]
fn simulate_writes_measurements_truth_and_true_robot_reproducibly() {
    let run = |tag: &str| {
        let out = tmp(&format!("sim_{tag}.csv"));
        let truth = tmp(&format!("sim_{tag}_truth.csv"));
        let robot = tmp(&format!("sim_{tag}_true.toml"));
        let o = robocal(&[
            "simulate",
            "--robot",
            FANUC,
            "--deviations",
            "datasets/deviations/table_6_1.toml",
            "--count",
            "20",
            "--seed",
            "42",
            "--sigma-pos",
            "0.033",
            "--sigma-rot",
            "0.174",
            "--measure",
            "position",
            "--out",
            out.to_str().unwrap(),
            "--truth-out",
            truth.to_str().unwrap(),
            "--true-robot",
            robot.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        (
            std::fs::read(&out).unwrap(),
            std::fs::read_to_string(&truth).unwrap(),
            std::fs::read_to_string(&robot).unwrap(),
        )
    };
    let (a, truth, true_robot) = run("a");
    let (b, _, _) = run("b");
    assert_eq!(a, b, "same seed, same bytes");
    let text = String::from_utf8(a).unwrap();
    assert!(
        text.starts_with("id,q1,q2,q3,q4,q5,q6,x,y,z,sx,sy,sz\n"),
        "{text}"
    );
    assert_eq!(text.lines().count(), 21);
    assert!(truth.starts_with("id,q1,q2,q3,q4,q5,q6,x,y,z\n"));
    assert!(true_robot.contains("beta = 0.0211994384"), "{true_robot}");
}

/// `simulate` streams its rows to the files; they are byte for byte the rows the library's
/// `Simulation::run` returns, written as a whole, for every kind of measurement and noise.
#[test]
fn simulate_streams_the_rows_the_library_returns() {
    use robocal::data::JointInfo;
    use robocal::data::measurement::measurements_to_csv;
    use robocal::model::read_robot;
    use robocal::sim::nongeometric::NonGeometric;
    use robocal::sim::{Configurations, Observe, Region, Simulation};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let robot = read_robot(root.join("datasets/robots/fanuc_r2000ib_210f.toml")).unwrap();
    let ng = NonGeometric::read(
        root.join("datasets/nongeometric/fanuc_compliance_gear.toml"),
        &robot,
    )
    .unwrap();
    let region = Region::read(root.join("datasets/regions/case_d_focused.toml"), &robot).unwrap();
    for (measure, observe, sigma) in [
        ("pose", Observe::Pose, 0.05),
        ("position", Observe::Position, 0.05),
        ("orientation", Observe::Orientation, 0.0),
    ] {
        let (out, truth) = (tmp("stream.csv"), tmp("stream_truth.csv"));
        let o = robocal(&[
            "simulate",
            "--robot",
            "datasets/robots/fanuc_r2000ib_210f.toml",
            "--nongeometric",
            "datasets/nongeometric/fanuc_compliance_gear.toml",
            "--region",
            "datasets/regions/case_d_focused.toml",
            "--count",
            "40",
            "--seed",
            "3",
            "--measure",
            measure,
            "--sigma-pos",
            &sigma.to_string(),
            "--sigma-rot",
            "0.2",
            "--out",
            out.to_str().unwrap(),
            "--truth-out",
            truth.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let sim = Simulation {
            truth: &robot,
            nongeometric: &ng,
            configurations: Configurations::Drawn {
                region: &region,
                count: 40,
            },
            seed: 3,
            sigma_position_mm: sigma,
            sigma_rotation_rad: 0.2e-3,
            observe,
        };
        let lib = sim.run(out.clone()).unwrap();
        let joints = JointInfo::of(&robot);
        assert_eq!(
            std::fs::read(&out).unwrap(),
            measurements_to_csv(&lib.measured, &joints).unwrap(),
            "{measure}"
        );
        assert_eq!(
            std::fs::read(&truth).unwrap(),
            measurements_to_csv(&lib.truth, &joints).unwrap(),
            "{measure}"
        );
    }
}

/// `simulate --joints` measures the given configurations in their order: the rows a drawn run
/// gave, its joints given back (the noise comes from its own stream, and backlash from the
/// order, so the rows agree), labelled and carried as the file has them, its joints written
/// as read; a row the robot cannot take, a file without rows and `--count` beside it are
/// refused, and nothing is written.
#[test]
fn simulate_measures_given_joints_in_their_order() {
    let ng = tmp("given_backlash.toml");
    std::fs::write(
        &ng,
        "[backlash]\nmrad = [0.5, 0.8, 0.6, 0.3, 0.3, 0.2]\n\n[[gear]]\njoint = 2\n\
         amplitude1_mrad = 0.04\nphase1_deg = 10.0\n",
    )
    .unwrap();
    let sim = |extra: &[&str], out: &std::path::Path, truth: &std::path::Path| {
        let mut args = vec![
            "simulate",
            "--robot",
            FANUC,
            "--deviations",
            "datasets/deviations/table_6_1.toml",
            "--nongeometric",
            ng.to_str().unwrap(),
            "--seed",
            "5",
            "--sigma-pos",
            "0.05",
            "--sigma-rot",
            "0.2",
            "--out",
            out.to_str().unwrap(),
            "--truth-out",
            truth.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        robocal(&args)
    };
    let (drawn, drawn_truth) = (tmp("given_drawn.csv"), tmp("given_drawn_truth.csv"));
    let o = sim(&["--count", "12"], &drawn, &drawn_truth);
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = |p: &std::path::Path| -> Vec<Vec<String>> {
        (std::fs::read_to_string(p).unwrap().lines())
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect()
    };
    let d = rows(&drawn);
    // The plan: its own ids, pairs and a note column, the drawn joints as text.
    let mut plan = String::from("id,pair,q1,q2,q3,q4,q5,q6,note\n");
    for (k, r) in d[1..].iter().enumerate() {
        plan += &format!("p{},{},{},n{k}\n", k + 1, k / 2 + 1, r[1..7].join(","));
    }
    let joints = tmp("given_plan.csv");
    std::fs::write(&joints, &plan).unwrap();
    let (given, given_truth) = (tmp("given_meas.csv"), tmp("given_meas_truth.csv"));
    let o = sim(
        &["--joints", joints.to_str().unwrap()],
        &given,
        &given_truth,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("simulated 12 configurations of"),
        "{}",
        stderr(&o)
    );
    for (a, b) in [(&drawn, &given), (&drawn_truth, &given_truth)] {
        let (a, b) = (rows(a), rows(b));
        assert_eq!(b[0][..2], ["id", "pair"]);
        assert_eq!(b[0].last().unwrap(), "note");
        assert_eq!(b.len(), 13);
        for (k, (ra, rb)) in a[1..].iter().zip(&b[1..]).enumerate() {
            assert_eq!(rb[0], format!("p{}", k + 1));
            assert_eq!(rb[1], (k / 2 + 1).to_string());
            assert_eq!(rb[2..8], ra[1..7], "joints as read");
            assert_eq!(rb.last().unwrap(), &format!("n{k}"));
            // x, y, z, rz, ry, rx: the same pose to float dust (the joints' trip through
            // the file), noise included.
            for c in 0..6 {
                let (va, vb): (f64, f64) = (ra[7 + c].parse().unwrap(), rb[8 + c].parse().unwrap());
                assert!((va - vb).abs() < 1e-8, "row {k} column {c}: {va} vs {vb}");
            }
        }
    }
    // Backlash makes the order matter: the rows reversed give other poses.
    let mut reversed = String::from("q1,q2,q3,q4,q5,q6\n");
    for r in d[1..].iter().rev() {
        reversed += &format!("{}\n", r[1..7].join(","));
    }
    std::fs::write(&joints, &reversed).unwrap();
    let o = sim(
        &["--joints", joints.to_str().unwrap()],
        &given,
        &given_truth,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (t, dt) = (rows(&given_truth), rows(&drawn_truth));
    assert_eq!(t[1][0], "1", "rows numbered without an id column");
    let moved = (1..13)
        .filter(|&k| {
            (t[k][7].parse::<f64>().unwrap() - dt[13 - k][7].parse::<f64>().unwrap()).abs() > 1e-6
        })
        .count();
    assert!(moved > 0, "backlash follows the order of the rows");
    // Refused, nothing written: a row beyond the limits, no rows, --count beside --joints.
    let limits_line = format!("q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0,0,{},0,0,0\n", 400.0);
    for (text, extra, said) in [
        (limits_line.as_str(), None, ":3: field `q3`: joint 3 at 400"),
        ("q1,q2,q3,q4,q5,q6\n", None, "no data rows"),
        (
            "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n",
            Some("--count"),
            "cannot be used with",
        ),
    ] {
        std::fs::write(&joints, text).unwrap();
        let (out, truth) = (tmp("given_refused.csv"), tmp("given_refused_truth.csv"));
        let _ = std::fs::remove_file(&out);
        let mut args = vec!["--joints", joints.to_str().unwrap()];
        if let Some(flag) = extra {
            args.extend([flag, "3"]);
        }
        let o = sim(&args, &out, &truth);
        assert!(!o.status.success());
        assert!(stderr(&o).contains(said), "{said}: {}", stderr(&o));
        assert!(!out.exists());
    }
}

/// Columns of a `--joints` file that a canonical reader would take as fields, in any letter
/// case (`x`, `X`, `SX`, `Q7`), are carried under `input_<name>`, with a note, so that the
/// file reads back (an `X` carried as read made `identify` refuse the file it had written).
#[test]
fn simulate_renames_carried_columns_a_reader_would_take() {
    let joints = tmp("given_fields.csv");
    std::fs::write(
        &joints,
        "q1,q2,q3,q4,q5,q6,X,x,SX,Q7,note\n\
         0,0,0,0,0,0,1,2,3,4,a\n10,-20,15,30,-40,50,1,2,3,4,b\n-30,25,-10,60,20,-70,1,2,3,4,c\n\
         45,10,30,-90,45,90,1,2,3,4,d\n-60,-30,20,120,-60,-120,1,2,3,4,e\n\
         90,5,-40,-30,80,30,1,2,3,4,f\n-100,40,45,150,-90,10,1,2,3,4,g\n\
         120,-40,-50,-150,30,-30,1,2,3,4,h\n",
    )
    .unwrap();
    let out = tmp("given_fields_out.csv");
    let o = robocal(&[
        "simulate",
        "--robot",
        FANUC,
        "--joints",
        joints.to_str().unwrap(),
        "--seed",
        "1",
        "--measure",
        "orientation",
        "--sigma-rot",
        "0.174",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("renamed: X as input_X, x as input_x, SX as input_SX, Q7 as input_Q7"),
        "{}",
        stderr(&o)
    );
    let header = std::fs::read_to_string(&out).unwrap();
    assert!(
        header.starts_with(
            "id,q1,q2,q3,q4,q5,q6,rz,ry,rx,srx,sry,srz,input_X,input_x,input_SX,input_Q7,note\n"
        ),
        "{header}"
    );
    let o = robocal(&[
        "evaluate",
        "--robot",
        FANUC,
        "--data",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A profile given as a pipe (`--profile /dev/stdin`, `<(...)`) can be read once only: it is
/// read once for the whole command (a second read found it empty and took the file for
/// canonical CSV).
#[test]
fn a_profile_from_a_pipe_is_read_once() {
    use std::io::Write;
    let input = tmp("piped_profile.csv");
    std::fs::write(&input, "q1;q2;q3;q4;q5;q6;x;y;z\n0;0;0;0;0;0;1,5;2;3\n").unwrap();
    let out = tmp("piped_profile.out.csv");
    let _ = std::fs::remove_file(&out);
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_robocal"))
        .args(["import", input.to_str().unwrap(), "--robot", FANUC])
        .args(["--profile", "/dev/stdin", "--out", out.to_str().unwrap()])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin
        .write_all(b"delimiter = \";\"\ndecimal_comma = true\n")
        .unwrap();
    drop(stdin);
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(written.contains(",1.5,2,3"), "{written}");
}

/// A deviations file with an angle of thousands of mrad (degrees written as mrad: 286 deg) is
/// simulated as given, with a warning naming it; the thesis's Table 6.1 gets none.
#[test]
fn deviations_far_beyond_a_robots_errors_are_warned_of() {
    let dev = tmp("large_dev.toml");
    std::fs::write(&dev, "alpha1 = 5000\na2 = 1.5\n").unwrap();
    let out = tmp("large_dev_sim.csv");
    let truth = tmp("large_dev_truth.toml");
    // Simulates `robot` with the deviations of `dev`: its stderr; the true robot in `truth`.
    let run = |robot: &str, dev: &str| {
        let o = robocal(&[
            "simulate",
            "--robot",
            robot,
            "--deviations",
            dev,
            "--count",
            "2",
            "--seed",
            "1",
            "--out",
            out.to_str().unwrap(),
            "--true-robot",
            truth.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let err = run(FANUC, dev.to_str().unwrap());
    assert!(
        err.contains("far beyond a robot's manufacturing errors: alpha1 5000 mrad")
            && !err.contains("a2"),
        "{err}"
    );
    assert!(!run(FANUC, "datasets/deviations/table_6_1.toml").contains("warning"));
    // A joint compliance is read in the robot file's unit (mrad per kN m): 0.5 is written
    // back as 0.5 in the true robot, 500 is warned of (it was read in rad per N m, a million
    // times larger, and warned of as 0.0005 mm at most; a reviewer's).
    let ur = "datasets/robots/ur10_published_masses.toml";
    for (value, warned) in [("0.5", false), ("500", true)] {
        std::fs::write(&dev, format!("c2 = {value}\n")).unwrap();
        let err = run(ur, dev.to_str().unwrap());
        assert_eq!(
            err.contains(&format!("c2 {value} mrad/kNm;")),
            warned,
            "{err}"
        );
        let text = std::fs::read_to_string(&truth).unwrap();
        assert!(
            text.contains(&format!("joints = [0.0, {value}.0, 0.0"))
                || text.contains(&format!("joints = [0.0, {value}, 0.0")),
            "{text}"
        );
    }
}
