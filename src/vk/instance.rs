//! Instance, debug messenger, physical-device choice, logical device: the
//! [`Context`] every executor of a process shares.

use std::ffi::{c_char, c_void, CStr};
use std::sync::{Arc, Mutex};

use ash::vk;

use super::error::{Check, VkError};
use super::layer_lock::{self, LayerUse};
use super::profile::DeviceProfile;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";

/// Which physical device to use (`--device auto|cpu|gpu`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DeviceChoice {
    /// A hardware device when present, else a software one.
    #[default]
    Auto,
    /// A software implementation (`PHYSICAL_DEVICE_TYPE_CPU`, e.g. lavapipe).
    Cpu,
    /// A discrete or integrated GPU; an error when there is none.
    Gpu,
}

/// How to create a [`Context`]: which device, and whether to validate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContextDesc {
    /// Which kind of device to pick.
    pub device: DeviceChoice,
    /// Enable `VK_LAYER_KHRONOS_validation` and collect its warnings and errors.
    pub validation: bool,
}

impl ContextDesc {
    /// Validation on in debug builds or with `PEELTRIM_VALIDATION=1`
    /// (`PEELTRIM_VALIDATION=0` turns it off).
    pub fn validation_default() -> bool {
        match std::env::var("PEELTRIM_VALIDATION").ok().as_deref() {
            Some("1") => true,
            Some("0") => false,
            _ => cfg!(debug_assertions),
        }
    }
}

impl Default for ContextDesc {
    fn default() -> Self {
        ContextDesc {
            device: DeviceChoice::Auto,
            validation: ContextDesc::validation_default(),
        }
    }
}

/// What presenting to a window needs of a new context (see `vk::present`): the
/// surface's instance extensions and a way to create the surface once the instance
/// exists. The device then gets `VK_KHR_swapchain` and a queue family that can
/// present to the surface.
pub(crate) struct PresentHooks<'a> {
    pub instance_extensions: &'a [*const c_char],
    pub create_surface: &'a dyn Fn(&ash::Entry, &ash::Instance) -> Result<vk::SurfaceKHR, VkError>,
}

type Messages = Mutex<Vec<String>>;

/// What the executors share. Dropped last, after every executor, image and buffer.
pub(crate) struct Shared {
    pub entry: ash::Entry,
    pub instance: ash::Instance,
    pub debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    /// Pointed to by the messenger's user data; outlives the messenger.
    pub messages: Arc<Messages>,
    pub physical: vk::PhysicalDevice,
    pub device: ash::Device,
    pub queue_family: u32,
    pub queue: vk::Queue,
    /// Held while submitting: `vkQueueSubmit` needs external synchronization, and
    /// executors of one context may live on different threads.
    pub queue_lock: Mutex<()>,
    pub limits: vk::PhysicalDeviceLimits,
    /// `sampleRateShading` is enabled: peeltrim's own devices enable it where
    /// supported; a host's device ([`Context::from_raw`]) is taken to have it
    /// enabled where supported (its `# Safety` asks for it).
    pub sample_rate_shading: bool,
    pub timestamp_valid_bits: u32,
    pub device_name: String,
    /// `None` only while dropping: freed before the device.
    pub allocator: Mutex<Option<gpu_allocator::vulkan::Allocator>>,
    /// Whether the instance and device were created here (not by [`Context::from_raw`]).
    pub owned: bool,
    /// Whether calls may go through the validation layer (ours on, or a host's
    /// device, which may have it): then they hold [`layer_lock::shared`].
    pub layered: bool,
}

impl Shared {
    /// Held by every entry point that calls Vulkan on this context (see `layer_lock`).
    pub fn layer_use(&self) -> LayerUse {
        layer_lock::shared(self.layered)
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        if let Ok(mut a) = self.allocator.lock() {
            let _layer = self.layer_use();
            a.take();
        }
        if !self.owned {
            return;
        }
        // Erasing the instance and device from the validation layer's table.
        let _table = self.debug.is_some().then(layer_lock::exclusive);
        // SAFETY: every child object (executors, images, buffers) holds an Arc to this
        // and is gone; waiting for idle makes destroying the device legal.
        unsafe {
            let _ = self.device.device_wait_idle();
        }
        // SAFETY: all device children are destroyed (see above).
        unsafe { self.device.destroy_device(None) };
        if let Some((du, messenger)) = self.debug.take() {
            // SAFETY: the messenger was created from this instance and is destroyed once.
            unsafe { du.destroy_debug_utils_messenger(messenger, None) };
        }
        // SAFETY: the device and messenger, the instance's only children, are gone.
        unsafe { self.instance.destroy_instance(None) };
    }
}

/// A Vulkan instance and device for running plans, and the device's profile
/// (what the executors and plans assume of it). Cheap to clone.
#[derive(Clone)]
pub struct Context {
    pub(crate) shared: Arc<Shared>,
    profile: DeviceProfile,
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the loader passes valid callback data for the duration of the call.
    let message = unsafe { (*data).message_as_c_str() }
        .map(|m| m.to_string_lossy().into_owned())
        .unwrap_or_default();
    // SAFETY: `user` points into the `Arc<Messages>` held by `Shared` (or by
    // `Context::new` while it runs), alive as long as the messenger that calls us.
    let messages = unsafe { &*(user as *const Messages) };
    let line = format!("[{severity:?}] {message}");
    eprintln!("vulkan validation: {line}");
    if let Ok(mut m) = messages.lock() {
        m.push(line);
    }
    vk::FALSE
}

fn debug_info(messages: &Arc<Messages>) -> vk::DebugUtilsMessengerCreateInfoEXT<'static> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(debug_callback))
        .user_data(Arc::as_ptr(messages) as *mut c_void)
}

fn device_type_rank(t: vk::PhysicalDeviceType) -> Option<u32> {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => Some(0),
        vk::PhysicalDeviceType::INTEGRATED_GPU => Some(1),
        vk::PhysicalDeviceType::VIRTUAL_GPU => Some(2),
        _ => None,
    }
}

impl Context {
    /// Creates a Vulkan 1.3 instance and device.
    pub fn new(desc: &ContextDesc) -> Result<Context, VkError> {
        Self::new_inner(desc, None).map(|(c, _)| c)
    }

    /// Like [`Context::new`], and with a surface made by `present` (returned; the
    /// caller destroys it before dropping the context) that the queue can present to.
    pub(crate) fn new_inner(
        desc: &ContextDesc,
        present: Option<&PresentHooks<'_>>,
    ) -> Result<(Context, vk::SurfaceKHR), VkError> {
        // SAFETY: loading the system Vulkan loader; its initialisation has no
        // preconditions beyond being a genuine loader library.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| VkError::Loader(e.to_string()))?;

        let messages: Arc<Messages> = Arc::new(Mutex::new(Vec::new()));
        let mut layers = Vec::new();
        let mut extensions = Vec::new();
        if desc.validation {
            // SAFETY: plain enumeration query on a loaded entry.
            let available = unsafe { entry.enumerate_instance_layer_properties() }
                .check("vkEnumerateInstanceLayerProperties")?;
            let found = available
                .iter()
                .any(|l| l.layer_name_as_c_str().ok() == Some(VALIDATION_LAYER));
            if !found {
                return Err(VkError::NoValidationLayer);
            }
            layers.push(VALIDATION_LAYER.as_ptr());
            extensions.push(ash::ext::debug_utils::NAME.as_ptr());
        }
        if let Some(p) = present {
            extensions.extend_from_slice(p.instance_extensions);
        }
        let app = vk::ApplicationInfo::default()
            .application_name(c"peeltrim")
            .api_version(vk::API_VERSION_1_3);
        // Adding the instance and device to the validation layer's table, until return.
        let _table = desc.validation.then(layer_lock::exclusive);
        let mut dbg = debug_info(&messages);
        let mut ci = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&extensions);
        if desc.validation {
            ci = ci.push_next(&mut dbg);
        }
        // SAFETY: the create info and everything it points to live across the call.
        let instance = unsafe { entry.create_instance(&ci, None) }.map_err(|e| match e {
            vk::Result::ERROR_INCOMPATIBLE_DRIVER => {
                VkError::Loader("the loader found no Vulkan 1.3 driver (ICD)".into())
            }
            e => VkError::Call {
                call: "vkCreateInstance",
                result: e,
            },
        })?;
        // From here on, `guard` destroys the instance if we bail out.
        struct InstanceGuard(Option<ash::Instance>);
        impl Drop for InstanceGuard {
            fn drop(&mut self) {
                if let Some(i) = self.0.take() {
                    // SAFETY: no children remain when we bail out before the device.
                    unsafe { i.destroy_instance(None) };
                }
            }
        }
        let mut guard = InstanceGuard(Some(instance.clone()));

        let debug = if desc.validation {
            let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
            let info = debug_info(&messages);
            // SAFETY: the user-data pointer (the Arc's contents) outlives the messenger.
            let m = unsafe { du.create_debug_utils_messenger(&info, None) }
                .check("vkCreateDebugUtilsMessengerEXT")?;
            Some((du, m))
        } else {
            None
        };
        let surface = match present {
            Some(p) => match (p.create_surface)(&entry, &instance) {
                Ok(s) => s,
                Err(e) => {
                    if let Some((du, m)) = &debug {
                        // SAFETY: created above from this instance, destroyed once here.
                        unsafe { du.destroy_debug_utils_messenger(*m, None) };
                    }
                    return Err(e);
                }
            },
            None => vk::SurfaceKHR::null(),
        };
        let surface_fn = ash::khr::surface::Instance::new(&entry, &instance);
        let destroy_debug =
            |debug: &Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>| {
                if surface != vk::SurfaceKHR::null() {
                    // SAFETY: created above from this instance; no swapchain uses it yet.
                    unsafe { surface_fn.destroy_surface(surface, None) };
                }
                if let Some((du, m)) = debug {
                    // SAFETY: created above from this instance, destroyed once on this path.
                    unsafe { du.destroy_debug_utils_messenger(*m, None) };
                }
            };

        let picked = Self::pick_physical(&instance, desc.device);
        let physical = match picked {
            Ok(p) => p,
            Err(e) => {
                destroy_debug(&debug);
                return Err(e);
            }
        };
        // SAFETY: `physical` was enumerated from `instance`.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let can_present = |i: usize| {
            present.is_none()
                // SAFETY: `physical` belongs to `instance`, `surface` is live, `i` is a
                // valid family index.
                || unsafe {
                    surface_fn.get_physical_device_surface_support(physical, i as u32, surface)
                }
                .unwrap_or(false)
        };
        let Some(queue_family) = families
            .iter()
            .enumerate()
            .position(|(i, f)| f.queue_flags.contains(vk::QueueFlags::GRAPHICS) && can_present(i))
            .map(|i| i as u32)
        else {
            destroy_debug(&debug);
            let what = if present.is_some() {
                "no graphics queue family that can present to the window"
            } else {
                "no graphics queue family"
            };
            return Err(VkError::NoDevice(what.into()));
        };
        let priorities = [1.0f32];
        let queue_ci = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            // Lets depth-only fragment shaders ignore the shared vertex outputs.
            .maintenance4(true);
        // Sample-rate shading where the device has it: multisampled frames
        // run their depth tests and texture reads once per sample.
        // SAFETY: `physical` was enumerated from `instance`; a plain query.
        let supported = unsafe { instance.get_physical_device_features(physical) };
        let features = vk::PhysicalDeviceFeatures::default()
            .sample_rate_shading(supported.sample_rate_shading == vk::TRUE);
        let device_extensions: Vec<*const c_char> = if present.is_some() {
            vec![ash::khr::swapchain::NAME.as_ptr()]
        } else {
            Vec::new()
        };
        let dci = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_ci)
            .enabled_extension_names(&device_extensions)
            .enabled_features(&features)
            .push_next(&mut f13);
        // SAFETY: valid create info; dynamicRendering is mandatory in Vulkan 1.3.
        let device = match unsafe { instance.create_device(physical, &dci, None) } {
            Ok(d) => d,
            Err(e) => {
                destroy_debug(&debug);
                return Err(VkError::Call {
                    call: "vkCreateDevice",
                    result: e,
                });
            }
        };
        // SAFETY: queue 0 of a family requested in the device create info.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        guard.0 = None;
        // From here on `Shared` owns the instance; the surface must go before it.
        let shared = Self::finish(
            entry,
            instance,
            debug,
            messages,
            physical,
            device,
            queue_family,
            queue,
            true,
        );
        // If `finish` fails, `Shared`'s Drop has already destroyed the device and
        // instance; a surface made here is then leaked with them (never used again).
        shared.map(|c| (c, surface))
    }

    fn pick_physical(
        instance: &ash::Instance,
        choice: DeviceChoice,
    ) -> Result<vk::PhysicalDevice, VkError> {
        // SAFETY: plain enumeration on a live instance.
        let all =
            unsafe { instance.enumerate_physical_devices() }.check("vkEnumeratePhysicalDevices")?;
        let mut candidates: Vec<(u32, vk::PhysicalDevice)> = Vec::new();
        let mut names = Vec::new();
        for p in all {
            // SAFETY: `p` was enumerated from `instance`.
            let props = unsafe { instance.get_physical_device_properties(p) };
            names.push(format!(
                "{} ({:?})",
                props
                    .device_name_as_c_str()
                    .unwrap_or(c"?")
                    .to_string_lossy(),
                props.device_type
            ));
            if props.api_version < vk::API_VERSION_1_3 {
                continue;
            }
            let hw = device_type_rank(props.device_type);
            let cpu = props.device_type == vk::PhysicalDeviceType::CPU;
            let rank = match choice {
                DeviceChoice::Cpu if cpu => Some(0),
                DeviceChoice::Gpu => hw,
                DeviceChoice::Auto => hw.or(if cpu { Some(10) } else { None }),
                _ => None,
            };
            if let Some(r) = rank {
                candidates.push((r, p));
            }
        }
        candidates.sort_by_key(|c| c.0);
        candidates.first().map(|c| c.1).ok_or_else(|| {
            let want = match choice {
                DeviceChoice::Auto => "any Vulkan 1.3 device",
                DeviceChoice::Cpu => {
                    "a Vulkan 1.3 CPU device (lavapipe: install mesa-vulkan-drivers)"
                }
                DeviceChoice::Gpu => "a Vulkan 1.3 hardware GPU (try --device cpu)",
            };
            VkError::NoDevice(format!("wanted {want}; found: [{}]", names.join(", ")))
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn finish(
        entry: ash::Entry,
        instance: ash::Instance,
        debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
        messages: Arc<Messages>,
        physical: vk::PhysicalDevice,
        device: ash::Device,
        queue_family: u32,
        queue: vk::Queue,
        owned: bool,
    ) -> Result<Context, VkError> {
        // SAFETY: `physical` belongs to `instance`.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        // The depth probe needs the device: measured below, once `Shared` is.
        let facts_instance = instance.clone();
        // SAFETY: as above.
        let families = unsafe { instance.get_physical_device_queue_family_properties(physical) };
        let timestamp_valid_bits = families
            .get(queue_family as usize)
            .map(|f| f.timestamp_valid_bits)
            .unwrap_or(0);
        let device_name = props
            .device_name_as_c_str()
            .unwrap_or(c"?")
            .to_string_lossy()
            .into_owned();
        let allocator =
            gpu_allocator::vulkan::Allocator::new(&gpu_allocator::vulkan::AllocatorCreateDesc {
                instance: instance.clone(),
                device: device.clone(),
                physical_device: physical,
                debug_settings: Default::default(),
                buffer_device_address: false,
                allocation_sizes: Default::default(),
            });
        let layered = debug.is_some() || !owned;
        // SAFETY: `physical` belongs to `instance`; a plain query.
        let sample_rate_shading = unsafe { instance.get_physical_device_features(physical) }
            .sample_rate_shading
            == vk::TRUE;
        // Build `Shared` first so its Drop cleans up even if the allocator failed.
        let mut shared = Shared {
            entry,
            instance,
            debug,
            messages,
            physical,
            device,
            queue_family,
            queue,
            queue_lock: Mutex::new(()),
            limits: props.limits,
            sample_rate_shading,
            timestamp_valid_bits,
            device_name,
            allocator: Mutex::new(None),
            layered,
            owned,
        };
        let allocator = allocator?;
        *shared
            .allocator
            .get_mut()
            .map_err(|_| VkError::Plan("poisoned".into()))? = Some(allocator);
        let shared = Arc::new(shared);
        let profile = DeviceProfile::detect(
            &facts_instance,
            physical,
            |bits, format| {
                let probe = super::depth_probe::measure(&shared, bits, format)?;
                Ok(probe.is_some_and(|p| p.unsnapped()))
            },
            |bits, format, samples| {
                let probe = super::sample_depth_probe::measure(&shared, bits, format, samples)?;
                Ok(probe.per_sample())
            },
        )?;
        Ok(Context { shared, profile })
    }

    /// Wraps a device created by an embedding application (a host engine).
    ///
    /// # Safety
    /// - `instance` was created from `entry` with API version 1.3 or later, and
    ///   `device` from `physical_device` of `instance` with Vulkan 1.3 and the
    ///   `dynamicRendering` and `maintenance4` features enabled, and
    ///   `sampleRateShading` too where the physical device supports it
    ///   (multisampled embedding, `EmbedDesc::samples`);
    /// - `queue` is a queue of family `queue_family`, which supports graphics;
    /// - the instance, device and queue stay valid until this context and every
    ///   executor made from it are dropped; the context does not destroy them;
    /// - the caller synchronizes access to `queue` with its own submissions
    ///   (executors submit to it and wait on their own fences).
    pub unsafe fn from_raw(
        entry: ash::Entry,
        instance: ash::Instance,
        physical_device: vk::PhysicalDevice,
        device: ash::Device,
        queue_family: u32,
        queue: vk::Queue,
    ) -> Result<Context, VkError> {
        let messages: Arc<Messages> = Arc::new(Mutex::new(Vec::new()));
        Self::finish(
            entry,
            instance,
            None,
            messages,
            physical_device,
            device,
            queue_family,
            queue,
            false,
        )
    }

    /// The physical device's name (e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`).
    pub fn device_name(&self) -> &str {
        &self.shared.device_name
    }

    /// Every validation warning and error reported so far.
    pub fn validation_messages(&self) -> Vec<String> {
        self.shared
            .messages
            .lock()
            .map(|m| m.clone())
            .unwrap_or_default()
    }

    /// Whether `format` works as a sampled, copyable depth-stencil attachment with
    /// optimal tiling: what the executor needs of a `--depth-format`
    /// ([`DeviceProfile::depth_formats`]).
    pub fn depth_format_usable(&self, format: vk::Format) -> bool {
        self.profile.depth_formats.usable(format)
    }

    /// The subpixel precision of the profile's vertex snapping: vertices are
    /// snapped to 2^-bits pixel before rasterization (at least 4 on a
    /// conformant device; the emulation's where one is on).
    pub fn subpixel_bits(&self) -> u32 {
        self.profile.subpixel_bits
    }

    /// What the executors and plans assume of the device
    /// ([`DeviceProfile::detect`]).
    pub fn profile(&self) -> &DeviceProfile {
        &self.profile
    }

    /// The same device under another profile (tests emulating a coarser
    /// device: [`DeviceProfile::emulating`]); executors made from it follow it.
    pub fn with_profile(&self, profile: DeviceProfile) -> Context {
        Context {
            shared: self.shared.clone(),
            profile,
        }
    }

    /// Shared use of the validation layer's table (`vk::layer_lock`) for a host's
    /// own calls on this context's device or instance (e.g. one made by
    /// [`Context::from_raw`]) while other threads create or drop contexts: held,
    /// no validated instance or device is created or destroyed in this process.
    /// peeltrim's own calls take it themselves.
    pub fn layer_use(&self) -> LayerUse {
        self.shared.layer_use()
    }

    /// Whether the validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.shared.debug.is_some()
    }

    /// The device (the host's, for a context from [`Context::from_raw`]).
    pub fn raw_device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// The instance.
    pub fn raw_instance(&self) -> &ash::Instance {
        &self.shared.instance
    }

    /// The loader's entry points.
    pub fn raw_entry(&self) -> &ash::Entry {
        &self.shared.entry
    }

    /// The physical device.
    pub fn raw_physical_device(&self) -> vk::PhysicalDevice {
        self.shared.physical
    }

    /// The queue family peeltrim records and submits for.
    pub fn queue_family(&self) -> u32 {
        self.shared.queue_family
    }

    /// The queue peeltrim submits to (its standalone frames, `LoopCounts::Learn`).
    pub fn raw_queue(&self) -> vk::Queue {
        self.shared.queue
    }
}
