use std::ops::ControlFlow;
use nnm::forced::*;
use nnm::model::*;
fn main() {
    let which = std::env::args().nth(1).unwrap_or_default();
    let mut settings = ResponseSettings::default();
    if std::env::var("NOEV").is_ok() { settings.events = false; }
    if let Ok(v) = std::env::var("MAXSTEP") { settings.continuation.max_step = v.parse().unwrap(); }
    if let Ok(v) = std::env::var("SAMPLES") { settings.samples = v.parse().unwrap(); }
    if which != "beam" {
    let disk = BladedDisk::default().build().unwrap();
    let modes = nnm::modes::linear_modes(&disk).unwrap();
    let r = modes.iter().find(|m| m.cyclic.as_ref().is_some_and(|c| c.diameters == 5 && c.circles == 1)).unwrap().frequency;
    let force = Force::EngineOrder { engine_order: 5, amplitude: 0.02, sector_dof: 1 };
    let c = damping::Damping::Rayleigh([0.0, 2e-3]).matrix(&disk).unwrap();
    let sys = ForcedSystem::new(&disk, &c, force.shape(&disk).unwrap()).unwrap();
    let t = std::time::Instant::now();
    let curve = forced_response(&sys, Sweep::Frequency { from: 0.9 * r, to: 1.1 * r, amplitude: 0.02 }, &[], &settings, |_| ControlFlow::Continue(())).unwrap();
    println!("disk r={r} {} points {:?} events {:?} {:.2}s {:?} {:?}", curve.points.len(), curve.stop, curve.events.iter().map(|e| (e.kind, e.point.frequency)).collect::<Vec<_>>(), t.elapsed().as_secs_f64(), curve.stats, curve.continuation);
    }
    if which != "disk" {
    let beam = nnm::model::CantileverBeam::default().build().unwrap();
    let bm = nnm::modes::linear_modes(&beam).unwrap();
    let w1 = bm[0].frequency;
    let c = damping::Damping::Rayleigh([0.0, 1e-5]).matrix(&beam).unwrap();
    let n = beam.dofs();
    let force = Force::Dofs { dofs: vec![n - 2], amplitude: 1.0 };
    let sys = ForcedSystem::new(&beam, &c, force.shape(&beam).unwrap()).unwrap();
    let t = std::time::Instant::now();
    let curve = forced_response(&sys, Sweep::Frequency { from: 0.9 * w1, to: 1.3 * w1, amplitude: 1.0 }, &[], &settings, |_| ControlFlow::Continue(())).unwrap();
    println!("beam w1={w1} n={n} {} points {:?} events {:?} {:.2}s {} peakmax {:e} {:?} {:?}", curve.points.len(), curve.stop, curve.events.iter().map(|e| (e.kind, e.point.frequency)).collect::<Vec<_>>(), t.elapsed().as_secs_f64(), curve.integrator, curve.points.iter().map(|p| p.peaks[0]).fold(0.0, f64::max), curve.stats, curve.continuation);
    }
}
