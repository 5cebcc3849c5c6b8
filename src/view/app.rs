//! The viewer's event loop: each redraw runs the script's next commands (or the user's input),
//! the UI, one frame through the scene's [`Renderer`], the presentation, and a capture when one
//! is due.

use super::camera::{CameraRig, MoveInput};
use super::capture::{self, WindowPixels};
use super::gpu::{render_frame, ui_renderer, FrameRequest, FrameTexture, UploadPool};
use super::passes::UiDraw;
use super::script::{Command, Script};
use super::settings::ViewSettings;
use super::swapchain::{Surface, Swapchain};
use super::ui::{self, Action, FrameTimes, SettingsView, TimingsView};
use super::{UiRenderer, ViewError, ViewOptions};
use crate::cli::CommonArgs;
use crate::gpu::{Context, ContextDesc, GpuError};
use crate::render::{FrameTiming, RenderOptions, Renderer};
use crate::scene::RenderSettings;
use std::cell::RefCell;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::ActiveEventLoop;
use winit::window::{Window, WindowId};

/// Everything on the GPU, dropped (in field order) once the device is idle.
struct Gpu {
    ui: RefCell<UiRenderer>,
    texture: FrameTexture,
    upload: UploadPool,
    renderer: Renderer,
    swapchain: Option<Swapchain>,
    surface: Surface,
    ctx: Arc<Context>,
}

impl Drop for Gpu {
    fn drop(&mut self) {
        if !self.ctx.has_failed() {
            let _ = unsafe { self.ctx.device.device_wait_idle() };
        }
        self.texture.remove_from(&mut self.ui.borrow_mut());
    }
}

/// A script's frames advance scene time by this much, so a script renders the same frames on
/// every machine.
const SCRIPT_DT: f32 = 1.0 / 30.0;
/// Time constant of the window's automatic exposure easing (eye adaptation), seconds.
const EXPOSURE_EASING_S: f32 = 0.5;

/// The viewer.
pub struct Viewer {
    opts: ViewOptions,
    settings: ViewSettings,
    script: Option<Script>,
    window: Option<Arc<Window>>,
    egui: Option<egui_winit::State>,
    gpu: Option<Gpu>,
    rig: Option<CameraRig>,
    /// Scene time, and whether it stands still.
    time: f32,
    paused: bool,
    dt: f32,
    /// Wall-clock time since the previous frame began, in ms (the frame time the user sees).
    wall_ms: f64,
    times: FrameTimes,
    last_timing: Option<FrameTiming>,
    last_frame: Option<Instant>,
    /// Frames rendered, in all and by the current renderer (a capture's `--frames`).
    frames: u64,
    renderer_frames: u32,
    /// A settings change the renderer refused, shown in the UI.
    notice: Option<String>,
    capture: Option<PathBuf>,
    captures: u32,
    remake_swapchain: bool,
    pub error: Option<crate::Error>,
}

impl Viewer {
    pub fn new(common: &CommonArgs, opts: ViewOptions, script: Option<Script>) -> Viewer {
        Viewer {
            settings: ViewSettings::new(common, &opts),
            opts,
            script,
            window: None,
            egui: None,
            gpu: None,
            rig: None,
            time: 0.0,
            paused: false,
            dt: 0.0,
            wall_ms: 0.0,
            times: FrameTimes { frames: Default::default() },
            last_timing: None,
            last_frame: None,
            frames: 0,
            renderer_frames: 0,
            notice: None,
            capture: None,
            captures: 0,
            remake_swapchain: false,
            error: None,
        }
    }

    /// The context, once started (to check validation after the loop).
    pub fn context(&self) -> Option<Arc<Context>> {
        self.gpu.as_ref().map(|g| g.ctx.clone())
    }

    /// Frames rendered, and the median wall-clock time of the last ones (ms).
    pub fn frames(&self) -> (u64, Option<f64>) {
        let mut wall: Vec<f64> = self.times.frames.iter().map(|f| f.0).collect();
        wall.sort_by(f64::total_cmp);
        (self.frames, wall.get(wall.len() / 2).copied())
    }

    /// The window, the device, the swapchain, the renderer and the UI.
    fn start(&mut self, event_loop: &ActiveEventLoop) -> crate::Result<()> {
        let scene = self.settings.load()?;
        let attrs = Window::default_attributes()
            .with_title(format!("dvsgi view: {}", scene.name))
            .with_inner_size(winit::dpi::PhysicalSize::new(self.opts.window.0, self.opts.window.1));
        let window = Arc::new(event_loop.create_window(attrs).map_err(|e| ViewError::Window(e.to_string()))?);
        let ctx = window_context(event_loop, &self.settings.common)?;
        let surface = Surface::new(&ctx, &window)?;
        let size = window.inner_size();
        let swapchain = Swapchain::new(&ctx, &surface, (size.width, size.height), self.opts.vsync, None)?;
        let format = swapchain.as_ref().map(|s| s.format).unwrap_or(ash::vk::Format::B8G8R8A8_SRGB);
        let options = RenderOptions { mode: self.settings.schedule, ..RenderOptions::default() };
        self.time = scene.settings.time;
        self.rig = Some(CameraRig::new(&scene.camera, scene_extent(&scene)));
        let render_size = (scene.settings.width, scene.settings.height);
        let mut renderer = Renderer::with_options(&ctx, scene, options)?;
        renderer.ease_exposure(self.exposure_easing());
        let mut ui = ui_renderer(&ctx, format, options.frames_in_flight as usize)?;
        let texture = FrameTexture::new(&ctx, &mut ui, render_size)?;
        let upload = UploadPool::new(&ctx)?;
        let max_side = ctx.info.limits.max_image_dimension2_d as usize;
        let egui_ctx = egui::Context::default();
        self.egui = Some(egui_winit::State::new(egui_ctx, egui::ViewportId::ROOT, &window, None, None, Some(max_side)));
        crate::outln!("device: {}", ctx.info.name);
        let mut gpu = Gpu { ui: RefCell::new(ui), texture, upload, renderer, swapchain, surface, ctx };
        adopt_swapchain(&mut gpu);
        self.gpu = Some(gpu);
        self.window = Some(window);
        Ok(())
    }

    /// One redraw: the script's commands, scene time, the swapchain, then the frame.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> crate::Result<()> {
        let now = Instant::now();
        let wall = self.last_frame.map(|l| (now - l).as_secs_f64()).unwrap_or(0.0);
        self.wall_ms = wall * 1e3;
        self.dt = if self.script.is_some() { SCRIPT_DT } else { wall.min(0.25) as f32 };
        self.last_frame = Some(now);
        if let Some(commands) = self.script.as_mut().map(|s| s.step()) {
            for c in commands {
                self.run_command(c, event_loop)?;
            }
        }
        if !self.ensure_swapchain()? {
            return Ok(()); // minimised
        }
        self.frame()?;
        if !self.paused {
            self.time += self.dt;
        }
        if self.script.as_ref().is_some_and(|s| s.done()) {
            event_loop.exit();
        }
        Ok(())
    }

    /// Remake the swapchain when asked or missing; false while the window has no area.
    fn ensure_swapchain(&mut self) -> crate::Result<bool> {
        let (Some(gpu), Some(window)) = (self.gpu.as_mut(), self.window.as_ref()) else { return Ok(false) };
        if self.remake_swapchain || gpu.swapchain.is_none() {
            let size = window.inner_size();
            if size.width == 0 || size.height == 0 {
                return Ok(false);
            }
            idle(&gpu.ctx)?;
            let mut old = gpu.swapchain.take();
            if old.as_ref().is_some_and(|s| s.surface_lost.get()) {
                // A lost surface's swapchain goes first, then the surface; both are made anew.
                old = None;
                gpu.surface = Surface::new(&gpu.ctx, window)?;
            }
            gpu.swapchain =
                Swapchain::new(&gpu.ctx, &gpu.surface, (size.width, size.height), self.opts.vsync, old.as_ref())?;
            drop(old);
            adopt_swapchain(gpu);
            self.remake_swapchain = false;
        }
        Ok(gpu.swapchain.is_some())
    }

    /// The UI, then the frame into the next swapchain image, its presentation and capture.
    fn frame(&mut self) -> crate::Result<()> {
        let (mut output, actions) = self.run_ui();
        if let Some(gpu) = self.gpu.as_mut() {
            update_ui_textures(gpu, std::mem::take(&mut output.textures_delta))?;
        }
        for a in actions {
            self.apply(a)?;
        }
        let (Some(gpu), Some(egui), Some(window), Some(rig)) =
            (self.gpu.as_mut(), self.egui.as_mut(), self.window.as_ref(), self.rig.as_ref())
        else {
            return Ok(());
        };
        egui.handle_platform_output(window, output.platform_output);
        let primitives = egui.egui_ctx().tessellate(output.shapes, output.pixels_per_point);
        gpu.renderer.scene.camera = rig.camera();
        let swapchain = gpu.swapchain.as_mut().expect("ensure_swapchain made it");
        let Some(acquired) = swapchain.acquire()? else {
            self.remake_swapchain = true;
            return Ok(());
        };
        let stem = self.capture.take();
        let error = RefCell::new(None);
        let draw = UiDraw {
            renderer: &gpu.ui,
            primitives: &primitives,
            pixels_per_point: output.pixels_per_point,
            error: &error,
        };
        let req = FrameRequest { time: self.time, readback: stem.is_some(), capture_window: stem.is_some(), draw };
        let swapchain = gpu.swapchain.as_ref().expect("acquired from it");
        let (stats, window_bytes) = render_frame(&mut gpu.renderer, &gpu.texture, swapchain, &acquired, req)?;
        if let Some(e) = error.into_inner() {
            return Err(ViewError::Ui(e).into());
        }
        self.remake_swapchain |= !swapchain.present(&acquired)?;
        let window_pixels = window_bytes.map(|bytes| WindowPixels {
            width: swapchain.extent.width,
            height: swapchain.extent.height,
            format: swapchain.format,
            bytes,
        });
        self.frames += 1;
        self.renderer_frames += 1;
        for t in gpu.renderer.take_timings() {
            self.times.push(self.wall_ms.max(stats.host_ms), t.gpu_span_ms());
            self.last_timing = Some(t);
        }
        match stem {
            Some(stem) => self.write_capture(&stem, window_pixels.as_ref()),
            None => Ok(()),
        }
    }

    /// Run the UI for this frame: what it drew and what the user asked for.
    fn run_ui(&mut self) -> (egui::FullOutput, Vec<Action>) {
        let (Some(gpu), Some(egui), Some(window), Some(rig)) =
            (self.gpu.as_ref(), self.egui.as_mut(), self.window.as_ref(), self.rig.as_ref())
        else {
            return (egui::FullOutput::default(), Vec::new());
        };
        let s = &gpu.renderer.scene.settings;
        let sky = gpu.renderer.scene.sky.as_ref();
        let value = |key: &str| match (key, sky) {
            ("sky.scale", Some(sky)) => Some(format!("{:?}", sky.scale)),
            ("sky.rotation", Some(sky)) => Some(format!("{:?}", sky.rotation_deg)),
            _ => setting_value(s, key),
        };
        let view = SettingsView {
            value: &value,
            schedule: self.settings.schedule,
            preset: self.settings.preset,
            camera: rig.mode,
            paused: self.paused,
            exposure: s.exposure,
            auto_exposure: s.exposure_auto.then(|| gpu.renderer.auto_exposure()),
            image_sky: sky.is_some_and(|s| matches!(s.kind, crate::scene::SkyKind::Image(_))),
        };
        let present_mode = gpu.swapchain.as_ref().map(|s| format!("{:?}", s.present_mode)).unwrap_or_default();
        let timings = TimingsView {
            device: &gpu.ctx.info.name,
            last: self.last_timing.as_ref(),
            times: &self.times,
            present_mode: &present_mode,
            size: (s.width, s.height),
        };
        let frame = (gpu.texture.id, (s.width as f32, s.height as f32));
        let notice = self.notice.as_deref();
        let mut actions = Vec::new();
        let input = egui.take_egui_input(window);
        let output = egui.egui_ctx().run_ui(input, |ui| {
            ui::layout(ui, &view, &timings, notice, frame, &mut actions);
        });
        (output, actions)
    }

    /// Carry out what the UI or the script asked for.
    fn apply(&mut self, a: Action) -> crate::Result<()> {
        let Some(rig) = self.rig.as_mut() else { return Ok(()) };
        match a {
            Action::Set(key, value) => return self.set(&key, &value),
            Action::Schedule(m) => {
                if let Some(gpu) = &mut self.gpu {
                    gpu.renderer.wait_idle()?;
                    gpu.renderer.set_mode(m)?;
                }
                self.settings.schedule = m;
            }
            Action::Preset(p) => {
                let (preset, changes) = (self.settings.preset, self.settings.changes.clone());
                self.settings.set_preset(p);
                if let Err(e) = self.rebuild() {
                    (self.settings.preset, self.settings.changes) = (preset, changes);
                    return self.refused("preset", e);
                }
            }
            Action::CameraMode(m) => rig.set_mode(m),
            Action::ResetCamera => rig.reset(),
            Action::Turn(dx, dy) => rig.turn(dx, dy),
            Action::Zoom(steps) => rig.zoom(steps),
            Action::Move(m) => rig.fly(m, self.dt),
            Action::Pause(p) => self.paused = p,
            Action::Capture => {
                self.captures += 1;
                self.capture = Some(PathBuf::from(format!("dvsgi-capture-{}", self.captures)));
            }
        }
        Ok(())
    }

    /// Automatic exposure eases over this many seconds in the window (eye adaptation), but
    /// not under a script, whose frames must be what `dvsgi render` makes of them.
    fn exposure_easing(&self) -> Option<f32> {
        self.script.is_none().then_some(EXPOSURE_EASING_S)
    }

    /// A setting: the exposure (a number, or "auto") changes in place, anything else rebuilds
    /// the renderer (or, if the renderer refuses the new settings, is undone and said in the UI).
    fn set(&mut self, key: &str, value: &str) -> crate::Result<()> {
        let previous = self.settings.set(key, value);
        if key == "render.exposure" {
            let auto = value.trim_matches('"') == "auto";
            if let (Some(gpu), Ok(ev)) = (&mut self.gpu, if auto { Ok(0.0) } else { value.parse::<f32>() }) {
                gpu.renderer.scene.settings.exposure = ev;
                gpu.renderer.scene.settings.exposure_auto = auto;
                return Ok(());
            }
        }
        match self.rebuild() {
            Ok(()) => Ok(()),
            Err(e) => {
                self.settings.revert(key, previous);
                self.refused(&format!("{key} = {value}"), e)
            }
        }
    }

    /// A change the renderer refused: fatal in a script (the script is wrong), said in the UI
    /// otherwise (the previous settings stay).
    fn refused(&mut self, what: &str, e: crate::Error) -> crate::Result<()> {
        if self.script.is_some() {
            return Err(e);
        }
        self.notice = Some(format!("{what}: {e}"));
        Ok(())
    }

    /// A new renderer for the current settings, replacing the old once it exists.
    fn rebuild(&mut self) -> crate::Result<()> {
        let easing = self.exposure_easing();
        let Some(gpu) = self.gpu.as_mut() else { return Ok(()) };
        let scene = self.settings.load()?;
        let size = (scene.settings.width, scene.settings.height);
        gpu.renderer.wait_idle()?;
        let options = RenderOptions { mode: self.settings.schedule, ..RenderOptions::default() };
        gpu.renderer = Renderer::with_options(&gpu.ctx, scene, options)?;
        gpu.renderer.ease_exposure(easing);
        let e = gpu.texture.image.desc.extent;
        if (e.width, e.height) != size {
            idle(&gpu.ctx)?;
            let texture = FrameTexture::new(&gpu.ctx, &mut gpu.ui.borrow_mut(), size)?;
            let old = std::mem::replace(&mut gpu.texture, texture);
            old.remove_from(&mut gpu.ui.borrow_mut());
        }
        adopt_swapchain(gpu);
        self.renderer_frames = 0;
        self.notice = None;
        Ok(())
    }

    /// One command of the script.
    fn run_command(&mut self, c: Command, event_loop: &ActiveEventLoop) -> crate::Result<()> {
        let deg = |d: f32| d.to_radians();
        match c {
            Command::Frames(_) => {}
            Command::Camera { position, target } => self.rig.iter_mut().for_each(|r| r.place(position, target)),
            Command::Turn { yaw_deg, pitch_deg } => self.apply(Action::Turn(deg(yaw_deg), deg(pitch_deg)))?,
            Command::Fly { forward, right, up, seconds } => {
                let m = MoveInput { forward, right, up, fast: false };
                self.rig.iter_mut().for_each(|r| r.fly(m, seconds));
            }
            Command::Orbit => self.apply(Action::CameraMode(super::camera::CameraMode::Orbit))?,
            Command::FlyMode => self.apply(Action::CameraMode(super::camera::CameraMode::Fly))?,
            Command::Set { key, value } => self.set(&key, &value)?,
            Command::Schedule(m) => self.apply(Action::Schedule(m))?,
            Command::Preset(p) => self.apply(Action::Preset(Some(p)))?,
            Command::Pause(p) => self.paused = p,
            Command::Capture(stem) => self.capture = Some(stem),
            Command::Resize { width, height } => {
                if let Some(w) = &self.window {
                    let _ = w.request_inner_size(winit::dpi::PhysicalSize::new(width, height));
                }
            }
            Command::Memory => self.print_memory(),
            Command::Quit => event_loop.exit(),
        }
        Ok(())
    }

    /// The GPU allocator's bytes and the process's resident set, for leak checks.
    fn print_memory(&self) {
        let gpu = self.gpu.as_ref().map(|g| g.ctx.allocated_bytes()).unwrap_or(0);
        crate::outln!("memory: frame {}: GPU allocator {gpu} bytes, resident {} bytes", self.frames, resident_bytes());
    }

    /// Write the capture of the frame just rendered, and say how to reproduce it.
    fn write_capture(&mut self, stem: &std::path::Path, window: Option<&WindowPixels>) -> crate::Result<()> {
        let Some(gpu) = &self.gpu else { return Ok(()) };
        let frame = gpu.renderer.output();
        let scene = self.settings.scene_file(&gpu.renderer.scene.camera, self.time)?;
        capture::write(stem, &frame, window, &scene)?;
        crate::outln!(
            "reproduce: dvsgi render {} --schedule {} --frames {} --out FILE.exr",
            capture::with_suffix(stem, ".toml").display(),
            self.settings.schedule.name(),
            self.renderer_frames
        );
        Ok(())
    }
}

/// A context that can present to windows of this event loop's display.
fn window_context(event_loop: &ActiveEventLoop, common: &CommonArgs) -> crate::Result<Arc<Context>> {
    let display = raw_window_handle::HasDisplayHandle::display_handle(event_loop)
        .map_err(|e| ViewError::Window(e.to_string()))?;
    let exts = ash_window::enumerate_required_extensions(display.as_raw())
        .map_err(|result| GpuError::Vk { call: "vkEnumerateInstanceExtensionProperties", result })?;
    // SAFETY: ash-window returns pointers to static extension-name strings.
    let exts: Vec<&'static std::ffi::CStr> = exts.iter().map(|p| unsafe { std::ffi::CStr::from_ptr(*p) }).collect();
    let desc = ContextDesc { validation: common.validation, device: common.device.clone() };
    Ok(Context::with_window(&desc, &exts)?)
}

/// Wait until the device has nothing left to do.
fn idle(ctx: &Context) -> crate::Result<()> {
    unsafe { ctx.device.device_wait_idle() }.map_err(|result| GpuError::Vk { call: "vkDeviceWaitIdle", result })?;
    Ok(())
}

/// The UI's new and changed textures uploaded before the frame that draws them, and those it
/// no longer needs freed once no frame in flight uses them. `delta` is handled whatever fails
/// (egui insists on it).
fn update_ui_textures(gpu: &mut Gpu, mut delta: egui::TexturesDelta) -> crate::Result<()> {
    let r = upload_ui_textures(gpu, &delta).and_then(|()| free_ui_textures(gpu, &delta));
    delta.clear();
    r
}

/// The UI's new and changed textures, uploaded.
fn upload_ui_textures(gpu: &Gpu, delta: &egui::TexturesDelta) -> crate::Result<()> {
    for (id, deltas) in &delta.set {
        for d in deltas {
            let _lock = gpu.ctx.submit_lock.lock().unwrap_or_else(|p| p.into_inner());
            gpu.ui
                .borrow_mut()
                .set_texture(gpu.ctx.graphics_queue.raw, gpu.upload.raw, *id, d)
                .map_err(|e| ViewError::Ui(e.to_string()))?;
        }
    }
    Ok(())
}

/// The UI's textures it no longer needs, freed once no frame in flight uses them (the frame
/// about to be drawn does not: egui frees only what it no longer draws).
fn free_ui_textures(gpu: &mut Gpu, delta: &egui::TexturesDelta) -> crate::Result<()> {
    if !delta.free.is_empty() {
        gpu.renderer.wait_idle()?;
        for id in &delta.free {
            gpu.ui.borrow_mut().free_texture(*id).map_err(|e| ViewError::Ui(e.to_string()))?;
        }
    }
    Ok(())
}

/// The swapchain's images start in the presentation engine's hands (for each new renderer's
/// barrier tracking, and after each swapchain is made).
fn adopt_swapchain(gpu: &mut Gpu) {
    if let Some(s) = &gpu.swapchain {
        for image in &s.images {
            gpu.renderer.adopt_presented(image);
        }
    }
}

/// The diagonal of the scene's bounds at its time (1 when empty): sets the flying speed.
fn scene_extent(scene: &crate::scene::Scene) -> f32 {
    let b = scene.world_bounds(scene.settings.time);
    let d = (b.max - b.min).length();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
    }
}

/// A setting the UI shows, as its TOML value (strings quoted), by dotted key.
fn setting_value(s: &RenderSettings, key: &str) -> Option<String> {
    let (table, name) = key.split_once('.')?;
    match (table, name) {
        ("gi", _) => toml::Value::try_from(&s.gi).ok()?.get(name).map(|v| v.to_string()),
        ("render", "view") => toml::Value::try_from(s.view).ok().map(|v| v.to_string()),
        ("render", "view_lod") => Some(format!("{:?}", s.view_lod)),
        _ => None,
    }
}

/// This process's resident memory in bytes (Linux; 0 elsewhere).
fn resident_bytes() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: u64 = statm.split_whitespace().nth(1).and_then(|p| p.parse().ok()).unwrap_or(0);
    pages * 4096
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_none() && self.error.is_none() {
            if let Err(e) = self.start(event_loop) {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match &event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(_) => self.remake_swapchain = true,
            WindowEvent::RedrawRequested => {
                if self.error.is_none() {
                    if let Err(e) = self.redraw(event_loop) {
                        self.error = Some(e);
                        event_loop.exit();
                    }
                }
                return;
            }
            _ => {}
        }
        if let (Some(egui), Some(window)) = (self.egui.as_mut(), self.window.as_ref()) {
            let _ = egui.on_window_event(window, &event);
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}
