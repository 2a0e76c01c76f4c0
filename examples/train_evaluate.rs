//! Train a neural compensator on what an identified model still misses, and evaluate it on
//! held-out measurements; save it and load it back.
//!
//! Run: `cargo run --release --example train_evaluate`

use robocal::data::read_canonical;
use robocal::evaluate::{row_errors, summarize};
use robocal::identify::{Measure, Options, identify};
use robocal::model::read_robot;
use robocal::neural::compensator::{Compensator, CompensatorOptions};
use robocal::neural::predict::PredictWorkspace;

fn main() -> robocal::Result<()> {
    let nominal = read_robot("datasets/robots/fanuc_r2000ib_210f.toml")?;
    let dir = std::path::Path::new("datasets/nongeometric_robot");
    let calibration = read_canonical(&dir.join("calibration.csv"), &nominal)?;
    let training = read_canonical(&dir.join("training.csv"), &nominal)?;
    let test = read_canonical(&dir.join("test.csv"), &nominal)?;

    let model = identify(&nominal, &calibration, &Options::default())?.robot;
    // Default options: form, inputs, size, penalty and ensemble chosen by cross-validation.
    let no_progress = |_: usize, _: usize| {};
    let (comp, report) = Compensator::train(
        &model,
        &training,
        &CompensatorOptions::default(),
        &no_progress,
    )?;
    println!("chosen by cross-validation: {}", report.settings.describe());

    let mut ws = PredictWorkspace::default();
    let model_rows = row_errors(&test, Measure::Pose, |q| {
        robocal::kinematics::tool_pose(&model, q)
    })?;
    let comp_rows = row_errors(&test, Measure::Pose, |q| comp.predict(q, &mut ws))?;
    for (name, rows) in [("model", &model_rows), ("model + network", &comp_rows)] {
        let p = summarize(rows).position_mm.expect("positions");
        println!(
            "{name:>16}: test position error mean {:.4} mm, RMS {:.4} mm",
            p.mean, p.rms
        );
    }

    // The compensator file is JSON text: save it anywhere, or keep it in memory.
    let text = comp.to_file_text()?;
    let again = Compensator::from_text(&text)?;
    let q = &test.rows[0].q;
    assert_eq!(again.predict(q, &mut ws), comp.predict(q, &mut ws));
    println!("compensator file: {} bytes", text.len());
    Ok(())
}
