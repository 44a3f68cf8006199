use std::ops::ControlFlow;
use std::path::Path;

use nnm::bifurcation::Event;
use nnm::modes::linear_modes;
use nnm::{BranchPoint, Observer, Start, continue_branch_observed};

use super::*;
use crate::job::parse_job;

/// The two-DOF backbone through its branch point (examples/two-dof-bifurcation.toml).
const JOB: &str = "[model]\nfamily = \"two-dof\"\ncubic = 0.5\n[settings]\nenergy_max = 100.0\n[[branch]]\nname = \"in-phase\"\nmode = 0\n";

/// Writes each point and event, then reads `<name>.json` back as a process killed right then
/// would leave it.
struct Checking<'a> {
    writer: &'a mut BranchWriter,
    json: PathBuf,
    points: usize,
    events: usize,
}

impl Checking<'_> {
    fn check(&self) {
        let text = std::fs::read_to_string(&self.json).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&text)
            .unwrap_or_else(|e| panic!("invalid JSON after a write ({e}): {text}"));
        assert_eq!(doc["status"], "running");
        assert_eq!(doc["name"], "in-phase");
        let points = doc["points"].as_array().unwrap();
        let events = doc["events"].as_array().unwrap();
        assert_eq!((points.len(), events.len()), (self.points, self.events));
        for (k, p) in points.iter().enumerate() {
            assert_eq!(p["index"], k);
            assert_eq!(p["z0"].as_array().unwrap().len(), 4);
        }
        for (k, e) in events.iter().enumerate() {
            assert_eq!(e["index"], k);
            assert_eq!(e["type"], "branch-point");
            assert_eq!(e["z0"].as_array().unwrap().len(), 4);
        }
    }
}

impl Observer for &mut Checking<'_> {
    fn point(&mut self, p: &BranchPoint) -> ControlFlow<()> {
        self.writer.write_point(p).unwrap();
        self.points += 1;
        self.check();
        ControlFlow::Continue(())
    }

    fn event(&mut self, e: &Event) -> ControlFlow<()> {
        self.writer.write_event(e).unwrap();
        self.events += 1;
        self.check();
        ControlFlow::Continue(())
    }
}

/// The JSON of a running branch is a valid document after every write, holding every point
/// and every event (with its state `z0`) written so far: what a killed run leaves; the
/// finished document holds the same.
#[test]
fn the_json_holds_every_point_and_event_after_each_write() {
    let dir = std::env::temp_dir().join(format!("nnm-io-{}-json", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let job = parse_job(JOB, Path::new("job.toml")).unwrap();
    let settings = &job.branches[0].settings;
    let modes = linear_modes(&job.structure).unwrap();
    let start = Start::for_branch(&job.structure, &modes, 0, None, settings).unwrap();
    let info = BranchInfo {
        name: "in-phase".into(),
        mode_index: 0,
        mode_label: "0".into(),
        pattern: None,
        travel: None,
        linear_frequency_rad_s: start.omega,
        symmetry: start.symmetry,
        switched_from: None,
        output_dofs: start.output_dofs(settings),
    };
    let mut writer = BranchWriter::create(&dir, info).unwrap();
    let mut checking = Checking {
        writer: &mut writer,
        json: dir.join("in-phase.json"),
        points: 0,
        events: 0,
    };
    checking.check();
    let branch = continue_branch_observed(&job.structure, &start, settings, &mut checking).unwrap();
    assert_eq!(checking.events, 1, "the branch point near E = 41");
    assert!(checking.points > 10);
    writer.finish(&branch, "done", 0.0).unwrap();
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("in-phase.json")).unwrap()).unwrap();
    assert_eq!(doc["status"], "finished");
    assert_eq!(doc["points"].as_array().unwrap().len(), branch.points.len());
    assert_eq!(doc["events"].as_array().unwrap().len(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}
