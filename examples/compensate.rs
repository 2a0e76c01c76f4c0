//! Turn desired tool poses into commands for an unmodified controller (thesis 2.7): the
//! controller keeps its nominal model, so it is sent the pose at which the nominal model
//! puts the joints where the calibrated robot reaches the desired pose.
//!
//! Run: `cargo run --release --example compensate`

use robocal::compensation::{CalibratedModel, FakeTargetSolver};
use robocal::data::{TargetTable, read_canonical};
use robocal::identify::{Options, identify};
use robocal::kinematics::pose_to_file;
use robocal::model::read_robot;

fn main() -> robocal::Result<()> {
    let nominal = read_robot("datasets/robots/fanuc_r2000ib_210f.toml")?;
    let calibration = read_canonical(
        "datasets/nongeometric_robot/calibration.csv".as_ref(),
        &nominal,
    )?;
    let calibrated = identify(&nominal, &calibration, &Options::default())?.robot;

    // Desired poses (x, y, z mm; rz, ry, rx deg) with optional seed joints q1..q6 (deg).
    let targets = TargetTable::read("datasets/targets/fanuc_cell.csv", &nominal, true)?;
    let mut solver = FakeTargetSolver::new(&nominal, CalibratedModel::identified(&calibrated))?;
    for (r, target) in targets.targets.iter().enumerate() {
        match solver.solve(target, targets.seeds[r].as_deref()) {
            Ok(c) => {
                let [x, y, z, rz, ry, rx] = pose_to_file(&c.fake);
                let moved = (c.fake.translation.vector - c.desired.translation.vector).norm();
                println!(
                    "row {}: branch {}, command x {x:.3} y {y:.3} z {z:.3} mm, rz {rz:.3} \
                     ry {ry:.3} rx {rx:.3} deg ({moved:.3} mm from the desired pose)",
                    r + 1,
                    // None only for a nominal model without a closed form.
                    c.branch.map_or_else(|| "-".into(), |b| b.to_string())
                );
            }
            Err(why) => println!("row {}: no command: {why}", r + 1),
        }
    }
    Ok(())
}
