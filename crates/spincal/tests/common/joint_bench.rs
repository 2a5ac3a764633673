//! The campaign of the `joint_fit_bench` example, shared with the scipy fixture test
//! (`joint_scipy`): the example includes this file by `#[path]`, so both build the same problem
//! without a public API for it. Changing it changes the problem the fixture
//! `tests/fixtures/joint_scipy/fit.json` was made on: re-run its `make.sh`.

use spincal::campaign::prepare::{prepare, Prepared};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup, SimulatedCampaign};

/// 6 still poses and the default 4 turntable runs of 2 minutes each (100 Hz), drawn by
/// `spincal::simulate` with `seed`, cut into the joint fit's inputs.
pub fn bench_campaign(seed: u64) -> Result<(SimulatedCampaign, Prepared), String> {
    let mut setup = CampaignSetup {
        poses: 6,
        ..CampaignSetup::default()
    };
    for run in &mut setup.runs {
        run.duration_s = 120.0;
    }
    let sim = simulate_campaign(&setup, seed).map_err(|e| format!("simulation, seed {seed}: {e}"))?;
    let prep = prepare(&sim.unit_recordings(false)).map_err(|e| format!("prepare, seed {seed}: {e}"))?;
    Ok((sim, prep))
}
