//! `realcam devices`: the GPU adapters `--device gpu` can render on.

use std::process::ExitCode;

use clap::Args;

use crate::gpu::{GpuContext, adapters};

#[derive(Args, Debug, Clone)]
pub struct DevicesArgs {
    /// Print the list as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &DevicesArgs) -> anyhow::Result<ExitCode> {
    let found = adapters();
    let chosen = GpuContext::shared()
        .ok()
        .map(|context| context.adapter.clone());
    if args.json {
        let list: Vec<serde_json::Value> = found
            .iter()
            .map(|adapter| {
                let mut value = serde_json::to_value(adapter).expect("plain data");
                value["chosen"] = serde_json::Value::Bool(chosen.as_ref() == Some(adapter));
                value
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "cpu: {} threads (--device cpu, the default)",
        rayon::current_num_threads()
    );
    if found.is_empty() {
        println!(
            "gpu: none found (wgpu looked for Vulkan, Metal and DX12 adapters; on Linux install a \
             Vulkan driver, e.g. Debian's mesa-vulkan-drivers for a software one)"
        );
    }
    for adapter in &found {
        let mark = if chosen.as_ref() == Some(adapter) {
            "  ← --device gpu"
        } else {
            ""
        };
        println!("gpu: {adapter}{mark}");
    }
    Ok(ExitCode::SUCCESS)
}
