//! Identify a robot's kinematic parameters from measurements in a CSV file and check the
//! identified model on measurements it has not seen.
//!
//! Run: `cargo run --release --example identify_csv`

use robocal::data::read_canonical;
use robocal::evaluate::evaluate_model;
use robocal::identify::{Options, identify};
use robocal::model::read_robot;

fn main() -> robocal::Result<()> {
    let nominal = read_robot("datasets/robots/fanuc_r2000ib_210f.toml")?;
    // 30 full poses measured by a tracker (Case D of the thesis, simulated).
    let calibration = read_canonical("datasets/case_d/calibration.csv".as_ref(), &nominal)?;
    let test = read_canonical("datasets/case_d/test.csv".as_ref(), &nominal)?;

    // Every identifiable geometric parameter, Levenberg-Marquardt (the defaults).
    let options = Options {
        params: "full".into(),
        ..Default::default()
    };
    let id = identify(&nominal, &calibration, &options)?;
    println!(
        "{} parameters identified, variance factor {:.3}",
        id.parameters.len(),
        id.variance_factor
    );
    for p in id.parameters.iter().take(5) {
        println!(
            "  {:<12} {:>10.4} -> {:>10.4} +- {:.4} {}",
            p.name, p.nominal, p.estimate, p.std, p.unit
        );
    }

    for (name, robot) in [("nominal", &nominal), ("identified", &id.robot)] {
        let stats = evaluate_model(robot, &test, id.measure)?;
        let pos = stats.position_mm.expect("the test set has positions");
        println!(
            "{name:>10}: test position error mean {:.4} mm, max {:.4} mm",
            pos.mean, pos.max
        );
    }
    Ok(())
}
