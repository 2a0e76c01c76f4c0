//! Load a robot, compute a tool pose (forward kinematics) and solve it back (inverse
//! kinematics, closed form), then check the round trip.
//!
//! Run: `cargo run --release --example fk_ik`

use robocal::kinematics::{IkOptions, IkSolver, IkStart, RobotModel, pose_to_file, tool_pose};
use robocal::model::read_robot;

fn main() -> robocal::Result<()> {
    // Files use mm and degrees; the library works in mm and radians.
    let robot = read_robot("datasets/robots/fanuc_r2000ib_210f.toml")?;
    let q = robot.joints_to_internal(&[10.0, 20.0, -10.0, 15.0, -50.0, 5.0]);
    let pose = tool_pose(&robot, &q);
    let [x, y, z, rz, ry, rx] = pose_to_file(&pose);
    println!("FK: x {x:.3} y {y:.3} z {z:.3} mm, rz {rz:.3} ry {ry:.3} rx {rx:.3} deg");

    // The IK strategy picks the robot's own closed form (thesis App. B) when it has one.
    let start = IkStart::choose(&robot, None)?;
    let mut ik = IkSolver::new(RobotModel::new(&robot), start, IkOptions::default());
    let every = ik.all(&pose, None).expect("the pose is reachable");
    println!("IK: {} solutions within the joint limits", every.len());
    let nearest = ik.nearest(&pose, Some(&q)).expect("reachable");
    let back = robot.joints_to_file(&nearest.solution.q);
    println!("IK nearest the seed: {back:.3?} deg");

    let again = tool_pose(&robot, &nearest.solution.q);
    let miss = (again.translation.vector - pose.translation.vector).norm();
    println!("FK -> IK -> FK position difference: {miss:.2e} mm");
    assert!(miss < 1e-9);
    Ok(())
}
