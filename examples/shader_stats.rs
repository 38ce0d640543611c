//! What the Vulkan driver makes of voxscope's ray casters: registers, shared and local memory,
//! and whatever else it reports through `VK_KHR_pipeline_executable_properties` (wgpu does not
//! expose it). Occupancy follows from the register count, and the benchmarks' few-sample rows
//! depend on it (docs/performance-log.md, run 38, "The bound on bricks against dense").
//!
//! `cargo run --release --example shader_stats` compiles each compute entry point of `raycast`
//! and `dense`, in each pipeline variant (plain, `SHADING`, `PROBE`: the override constants),
//! from WGSL to SPIR-V with naga as wgpu does (overrides processed, bounds checks as wgpu
//! applies them), builds a pipeline on the first Vulkan device that has the extension, and
//! prints its statistics. `shader_stats FILE.wgsl:ENTRY[:NAME=VALUE,…] …` measures those entry
//! points of those (composed) WGSL files, with those override constants, instead: variants of
//! a shader (or an older version of it), compared without rebuilding.
//! (NVIDIA's driver 580 offers statistics but no internal representations; Mesa's lavapipe
//! in Debian 12 does not offer the extension.)

use std::ffi::CStr;

use ash::vk;
use naga::back::spv;
use naga::proc::{BoundsCheckPolicies, BoundsCheckPolicy};

fn main() {
    if let Err(problem) = run() {
        eprintln!("shader_stats: {problem}");
        std::process::exit(1);
    }
}

/// The entry points measured: shader name in `voxscope_render::shaders::ALL`, entry point.
const ENTRY_POINTS: [(&str, &str); 3] = [
    ("raycast", "main"),
    ("raycast", "main_bricks"),
    ("dense", "main"),
];

/// The pipeline variants of each entry point measured (voxscope-render's pipeline.rs, `Variant`):
/// their override constants.
const VARIANTS: [&str; 5] = ["", "SHADING=1", "PROBE=1", "CLIP=1", "SHADING=1,CLIP=1"];

/// One pipeline to measure: a label, WGSL source, entry point and override constants.
struct Measured {
    label: String,
    source: String,
    entry_point: String,
    constants: naga::back::PipelineConstants,
}

fn run() -> Result<(), String> {
    let entry = unsafe { ash::Entry::load() }.map_err(|e| format!("no Vulkan loader: {e}"))?;
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    let instance = unsafe {
        entry.create_instance(
            &vk::InstanceCreateInfo::default().application_info(&app),
            None,
        )
    }
    .map_err(|e| format!("cannot create a Vulkan instance: {e}"))?;
    let result = with_instance(&instance);
    unsafe { instance.destroy_instance(None) };
    result
}

fn with_instance(instance: &ash::Instance) -> Result<(), String> {
    let extension = ash::khr::pipeline_executable_properties::NAME;
    let physical = unsafe { instance.enumerate_physical_devices() }
        .map_err(|e| format!("cannot list devices: {e}"))?
        .into_iter()
        .find(|&device| {
            unsafe { instance.enumerate_device_extension_properties(device) }
                .unwrap_or_default()
                .iter()
                .any(|p| p.extension_name_as_c_str() == Ok(extension))
        })
        .ok_or("no Vulkan device offers VK_KHR_pipeline_executable_properties")?;
    let properties = unsafe { instance.get_physical_device_properties(physical) };
    let name = properties
        .device_name_as_c_str()
        .map_or("?".into(), CStr::to_string_lossy);
    println!(
        "device: {name} (driver version {:#x})",
        properties.driver_version
    );
    let queue_family = unsafe { instance.get_physical_device_queue_family_properties(physical) }
        .iter()
        .position(|family| family.queue_flags.contains(vk::QueueFlags::COMPUTE))
        .ok_or("no compute queue")? as u32;

    let mut executable_info = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default()
        .pipeline_executable_info(true);
    let priorities = [1.0];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(queue_family)
        .queue_priorities(&priorities)];
    let extensions = [extension.as_ptr()];
    let device_info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .enabled_extension_names(&extensions)
        .push_next(&mut executable_info);
    let device = unsafe { instance.create_device(physical, &device_info, None) }
        .map_err(|e| format!("cannot create the device: {e}"))?;
    let executables = ash::khr::pipeline_executable_properties::Device::new(instance, &device);

    let mut result = Ok(());
    for measured in shaders_to_measure()? {
        result = report(&device, &executables, &measured);
        if result.is_err() {
            break;
        }
    }
    unsafe { device.destroy_device(None) };
    result
}

/// Each pipeline to measure: the command line's `FILE.wgsl:ENTRY[:NAME=VALUE,…]` arguments, or
/// else every [`VARIANTS`] of [`ENTRY_POINTS`] of voxscope's own shaders.
fn shaders_to_measure() -> Result<Vec<Measured>, String> {
    let arguments: Vec<String> = std::env::args().skip(1).collect();
    if arguments.is_empty() {
        let mut measured = Vec::new();
        for &(shader, entry_point) in &ENTRY_POINTS {
            let found = voxscope_render::shaders::ALL
                .iter()
                .find(|s| s.name == shader)
                .ok_or_else(|| format!("no shader {shader}"))?;
            for variant in VARIANTS {
                measured.push(Measured {
                    label: shader.to_owned(),
                    source: found.source.to_owned(),
                    entry_point: entry_point.to_owned(),
                    constants: parse_constants(variant)?,
                });
            }
        }
        return Ok(measured);
    }
    arguments
        .iter()
        .map(|argument| {
            let (file, rest) = argument
                .split_once(".wgsl:")
                .ok_or_else(|| format!("{argument}: expected FILE.wgsl:ENTRY[:NAME=VALUE,…]"))?;
            let file = format!("{file}.wgsl");
            let (entry_point, constants) = rest.split_once(':').unwrap_or((rest, ""));
            let source = std::fs::read_to_string(&file).map_err(|e| format!("{file}: {e}"))?;
            Ok(Measured {
                label: file,
                source,
                entry_point: entry_point.to_owned(),
                constants: parse_constants(constants)?,
            })
        })
        .collect()
}

/// `NAME=VALUE,…` (empty: none) as naga's pipeline constants (`true` is 1).
fn parse_constants(text: &str) -> Result<naga::back::PipelineConstants, String> {
    text.split(',')
        .filter(|part| !part.is_empty())
        .map(|part| {
            let (name, value) = part
                .split_once('=')
                .ok_or_else(|| format!("{part}: expected NAME=VALUE"))?;
            let value = value
                .parse::<f64>()
                .map_err(|_| format!("{part}: the value is not a number"))?;
            Ok((name.to_owned(), value))
        })
        .collect()
}

/// Compiles one entry point, builds its pipeline and prints what the driver reports.
fn report(
    device: &ash::Device,
    executables: &ash::khr::pipeline_executable_properties::Device,
    measured: &Measured,
) -> Result<(), String> {
    let constants: Vec<String> = measured
        .constants
        .iter()
        .map(|(name, value)| format!("{name}={value}"))
        .collect();
    let shader = &if constants.is_empty() {
        measured.label.clone()
    } else {
        format!("{}[{}]", measured.label, constants.join(","))
    };
    let entry_point = measured.entry_point.as_str();
    let module =
        naga::front::wgsl::parse_str(&measured.source).map_err(|e| format!("{shader}: {e}"))?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| format!("{shader}: {e:?}"))?;
    // As wgpu does before writing SPIR-V: the override constants replaced by their values, and
    // the module compacted to what the entry point uses.
    let (module, info) = naga::back::pipeline_constants::process_overrides(
        &module,
        &info,
        Some((naga::ShaderStage::Compute, entry_point)),
        &measured.constants,
    )
    .map_err(|e| format!("{shader}/{entry_point}: overrides: {e}"))?;
    let options = spv::Options {
        // As wgpu compiles shaders unless told they are trusted.
        bounds_check_policies: BoundsCheckPolicies {
            index: BoundsCheckPolicy::Restrict,
            buffer: BoundsCheckPolicy::Restrict,
            image_load: BoundsCheckPolicy::Restrict,
            binding_array: BoundsCheckPolicy::Restrict,
        },
        ..spv::Options::default()
    };
    let pipeline_options = spv::PipelineOptions {
        shader_stage: naga::ShaderStage::Compute,
        entry_point: entry_point.to_owned(),
    };
    let words = spv::write_vec(&module, &info, &options, Some(&pipeline_options))
        .map_err(|e| format!("{shader}/{entry_point}: SPIR-V: {e}"))?;

    // One descriptor set per @group, a binding per global resource (unused ones included:
    // a layout may declare more than the entry point reads).
    let mut sets: Vec<Vec<vk::DescriptorSetLayoutBinding>> = Vec::new();
    for (_, global) in module.global_variables.iter() {
        let Some(binding) = &global.binding else {
            continue;
        };
        let kind = match (global.space, &module.types[global.ty].inner) {
            (naga::AddressSpace::Uniform, _) => vk::DescriptorType::UNIFORM_BUFFER,
            (naga::AddressSpace::Storage { .. }, _) => vk::DescriptorType::STORAGE_BUFFER,
            (_, naga::TypeInner::Sampler { .. }) => vk::DescriptorType::SAMPLER,
            (
                _,
                naga::TypeInner::Image {
                    class: naga::ImageClass::Storage { .. },
                    ..
                },
            ) => vk::DescriptorType::STORAGE_IMAGE,
            (_, naga::TypeInner::Image { .. }) => vk::DescriptorType::SAMPLED_IMAGE,
            (space, _) => return Err(format!("{shader}: a resource in {space:?}")),
        };
        let group = binding.group as usize;
        if sets.len() <= group {
            sets.resize(group + 1, Vec::new());
        }
        sets[group].push(
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding.binding)
                .descriptor_type(kind)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE),
        );
    }

    let mut set_layouts = Vec::new();
    for bindings in &sets {
        let layout = unsafe {
            device.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings),
                None,
            )
        }
        .map_err(|e| format!("descriptor set layout: {e}"))?;
        set_layouts.push(layout);
    }
    let layout = unsafe {
        device.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts),
            None,
        )
    }
    .map_err(|e| format!("pipeline layout: {e}"))?;
    let shader_module = unsafe {
        device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
    }
    .map_err(|e| format!("shader module: {e}"))?;
    let entry_name = std::ffi::CString::new(entry_point).expect("no NUL in entry point names");
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(shader_module)
        .name(&entry_name);
    let create_info = vk::ComputePipelineCreateInfo::default()
        .flags(vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR)
        .stage(stage)
        .layout(layout);
    let pipeline =
        unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &[create_info], None) }
            .map_err(|(_, e)| format!("{shader}/{entry_point}: pipeline: {e}"))?[0];

    let printed = print_executables(executables, pipeline, shader, entry_point);
    unsafe {
        device.destroy_pipeline(pipeline, None);
        device.destroy_shader_module(shader_module, None);
        device.destroy_pipeline_layout(layout, None);
        for set_layout in set_layouts {
            device.destroy_descriptor_set_layout(set_layout, None);
        }
    }
    printed
}

fn print_executables(
    executables: &ash::khr::pipeline_executable_properties::Device,
    pipeline: vk::Pipeline,
    shader: &str,
    entry_point: &str,
) -> Result<(), String> {
    let pipeline_info = vk::PipelineInfoKHR::default().pipeline(pipeline);
    let properties = unsafe { executables.get_pipeline_executable_properties(&pipeline_info) }
        .map_err(|e| format!("executable properties: {e}"))?;
    for (index, executable) in properties.iter().enumerate() {
        println!(
            "{shader}/{entry_point} [{}] subgroup size {}",
            executable
                .name_as_c_str()
                .map_or("?".into(), CStr::to_string_lossy),
            executable.subgroup_size
        );
        let executable_info = vk::PipelineExecutableInfoKHR::default()
            .pipeline(pipeline)
            .executable_index(index as u32);
        let statistics =
            unsafe { executables.get_pipeline_executable_statistics(&executable_info) }
                .map_err(|e| format!("statistics: {e}"))?;
        for statistic in &statistics {
            let value = unsafe {
                match statistic.format {
                    vk::PipelineExecutableStatisticFormatKHR::BOOL32 => {
                        (statistic.value.b32 != 0).to_string()
                    }
                    vk::PipelineExecutableStatisticFormatKHR::INT64 => {
                        statistic.value.i64.to_string()
                    }
                    vk::PipelineExecutableStatisticFormatKHR::UINT64 => {
                        statistic.value.u64.to_string()
                    }
                    _ => statistic.value.f64.to_string(),
                }
            };
            println!(
                "    {:<32} {value}",
                statistic
                    .name_as_c_str()
                    .map_or("?".into(), CStr::to_string_lossy)
            );
        }
    }
    Ok(())
}
