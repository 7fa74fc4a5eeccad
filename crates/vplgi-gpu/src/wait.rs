//! Waiting for the device, the one way the host blocks on it: read-backs, stage boundaries and
//! the timestamp read-back all wait here, with one timeout.

use crate::GpuError;

/// How long the host may wait for the device before it counts as lost (lavapipe is slow, but
/// not this slow).
const TIMEOUT: std::time::Duration = std::time::Duration::from_secs(600);

/// Waits until the device has finished all submitted work; `what` names the wait in the error.
pub fn wait_for_device(device: &wgpu::Device, what: &str) -> Result<(), GpuError> {
    device
        .poll(wgpu::PollType::Wait { submission_index: None, timeout: Some(TIMEOUT) })
        .map(|_| ())
        .map_err(|e| GpuError::Lost { what: what.into(), message: e.to_string() })
}
