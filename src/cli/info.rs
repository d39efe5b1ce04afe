//! `pathlight info`: the Vulkan adapters and the CPU backend's threads.

use pathlight::gpu::{describe_adapter, enumerate_adapters};
use pathlight::Error;

pub fn run() -> Result<(), Error> {
    let adapters = enumerate_adapters();
    if adapters.is_empty() {
        out!("no Vulkan adapters found (render falls back to the CPU backend)");
    }
    for (i, a) in adapters.iter().enumerate() {
        out!("[{i}] {}", describe_adapter(a));
    }
    out!("CPU reference: {} threads", rayon::current_num_threads());
    Ok(())
}
