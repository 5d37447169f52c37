//! The GPU for the commands that render on it (`render`, `converge`): opened once, and, when
//! what was found is a software device, said so on standard error, with why it is slow.

use crate::error::Error;
use crate::gpu::Gpu;

/// Opens the GPU (the adapter [`crate::gpu::Adapter::find`] takes). On a software adapter
/// (lavapipe, llvmpipe, WARP) it warns on standard error, whatever `--quiet` says: the CPU
/// path renders faster there, and no hardware GPU was found.
pub(crate) fn open_gpu() -> Result<Gpu, Error> {
    let gpu = Gpu::new().map_err(|e| Error::Resource(e.to_string()))?;
    if let Some(note) = gpu.software_note() {
        eprintln!("warning: {note}");
    }
    Ok(gpu)
}

/// The line `check` gives for the GPU: the adapter a render would take, or why there is none
/// (a check needs none).
pub(crate) fn adapter_line() -> String {
    match crate::gpu::Adapter::find() {
        Ok(a) => match a.software_note() {
            Some(_) => format!(
                "{}, a software device (it runs on the CPU, where --device cpu renders faster)",
                a.describe()
            ),
            None => a.describe(),
        },
        Err(e) => format!("none here, which rendering needs ({e})"),
    }
}
