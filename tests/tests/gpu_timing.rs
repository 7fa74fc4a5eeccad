//! GPU timing from timestamp queries (`vplgi_gpu::timing`), which the benches report.

use std::time::{Duration, Instant};
use vplgi_gpu::rng::rng_streams;
use vplgi_gpu::timing::{device_time, supported};

/// The device time of a kernel is positive, within the wall time around it (which also pays
/// pipeline compilation and read-back), and grows with the work.
#[test]
fn device_time_is_positive_within_wall_time_and_grows_with_work() {
    let Some(ctx) =
        vplgi_tests::gpu("device_time_is_positive_within_wall_time_and_grows_with_work")
    else {
        return;
    };
    let run = |count: u32| -> (Option<Duration>, Duration) {
        let t0 = Instant::now();
        let (draws, time) = device_time(&ctx.device, &ctx.queue, || {
            rng_streams(&ctx.device, &ctx.queue, 1, 1, 0, count, 64)
        })
        .unwrap();
        assert_eq!(draws.unwrap().len(), count as usize * 64);
        (time, t0.elapsed())
    };
    if !supported(&ctx.device) {
        println!("the adapter has no timestamp queries: device_time gives None");
        assert!(run(64).0.is_none());
        return;
    }
    run(1 << 10);
    let (small, small_wall) = run(1 << 10);
    let (big, big_wall) = run(1 << 18);
    let (small, big) = (small.unwrap(), big.unwrap());
    println!("device time {small:?} of {small_wall:?} wall for 64 Ki draws, {big:?} of {big_wall:?} for 16 Mi draws");
    assert!(small > Duration::ZERO && small <= small_wall);
    assert!(big <= big_wall);
    assert!(big > small, "256x the work took no longer");
}
