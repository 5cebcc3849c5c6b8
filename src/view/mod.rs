//! `dvsgi view`: the renderer in a window, its settings live and its GPU timings drawn.
//!
//! The viewer adds only a surface, three passes (copy the display image for the UI, draw the
//! UI, present) and the UI to the same [`crate::render::Renderer`] and frame list `dvsgi
//! render` uses; their barriers come from their declared uses like every pass's.

mod app;
mod camera;
mod capture;
mod gpu;
mod passes;
mod script;
mod settings;
mod swapchain;
mod ui;

pub use script::Script;

use crate::cli::CommonArgs;
use crate::render::Mode;
use std::path::PathBuf;

type UiRenderer = egui_ash_renderer::Renderer<egui_ash_renderer::allocator::DefaultAllocator>;

/// What can go wrong in the viewer beyond the renderer's own errors.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error(
        "no display to open a window on: {0}\n  \
         set DISPLAY (X11) or WAYLAND_DISPLAY, or run under a virtual display (xvfb-run dvsgi view ...);\n  \
         `dvsgi render` renders without one"
    )]
    NoDisplay(String),
    #[error("window: {0}")]
    Window(String),
    #[error("{}{}: {message}", path.display(), if *line > 0 { format!(", line {line}") } else { String::new() })]
    Script { path: PathBuf, line: usize, message: String },
    #[error("UI renderer: {0}")]
    Ui(String),
    /// The GPU layer's error, where a viewer step (surface, UI texture) meets one.
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
}

/// `dvsgi view`'s options beyond the common ones.
pub struct ViewOptions {
    pub scene: PathBuf,
    pub schedule: Mode,
    /// The window's initial inner size in pixels.
    pub window: (u32, u32),
    /// Present in step with the display (FIFO) instead of as fast as frames come.
    pub vsync: bool,
    /// Size overrides from the command line (`render.width`, ...), before any change.
    pub size: Vec<(String, String)>,
}

/// Open the window and run until it is closed or the script ends; then fail if validation
/// reported errors.
pub fn run(common: &CommonArgs, opts: ViewOptions, script: Option<&std::path::Path>) -> crate::Result<()> {
    let script = script.map(Script::load).transpose()?;
    if let Some(s) = &script {
        for stem in s.captures() {
            crate::output::check_target_dir(&capture::with_suffix(stem, ".png"))?;
        }
    }
    let event_loop = winit::event_loop::EventLoop::new().map_err(|e| ViewError::NoDisplay(e.to_string()))?;
    event_loop.set_control_flow(winit::event_loop::ControlFlow::Poll);
    let mut viewer = app::Viewer::new(common, opts, script);
    event_loop.run_app(&mut viewer).map_err(|e| ViewError::Window(e.to_string()))?;
    if let Some(e) = viewer.error.take() {
        return Err(e);
    }
    let ctx = viewer.context();
    let (frames, median) = viewer.frames();
    drop(viewer);
    match median {
        Some(ms) => crate::outln!("frames: {frames} (median {ms:.1} ms wall clock per frame)"),
        None => crate::outln!("frames: {frames}"),
    }
    match ctx {
        Some(ctx) => crate::cli::check_validation(&ctx),
        None => Ok(()),
    }
}
