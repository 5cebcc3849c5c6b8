//! The viewer's UI: the frame, its settings (technique, schedule, preset, each technique's
//! main knobs, debug views, exposure, camera) and its timings (the last frame's passes on the
//! graphics and compute queues, and the frame times of the last seconds).

use super::camera::{CameraMode, MoveInput};
use crate::render::graph::QueueKind;
use crate::render::{FrameTiming, Mode};
use crate::scene::Preset;
use egui::{Color32, Pos2, Rect, Sense, Stroke, Vec2};
use std::collections::VecDeque;

/// What the user asked for this frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// A scene setting (dotted key, TOML value), as `--set`.
    Set(String, String),
    Schedule(Mode),
    Preset(Option<Preset>),
    CameraMode(CameraMode),
    ResetCamera,
    /// Turn the camera by (yaw, pitch) radians (a drag over the frame).
    Turn(f32, f32),
    /// Orbit nearer by this many wheel notches.
    Zoom(f32),
    /// Fly with the movement keys held this frame.
    Move(MoveInput),
    Pause(bool),
    Capture,
}

/// One setting the UI shows, by its scene-file key.
#[derive(Clone)]
enum Knob {
    /// One of a few TOML values (strings quoted, numbers bare).
    Choice(&'static str, &'static str, &'static [&'static str]),
    Toggle(&'static str, &'static str),
    Number(&'static str, &'static str, f32, f32),
}

const TECHNIQUES: &[&str] = &["\"none\"", "\"vct\"", "\"rsm\"", "\"lpv\"", "\"rsm+lpv\""];
const VIEWS: &[&str] = &[
    "\"final\"",
    "\"indirect\"",
    "\"ao\"",
    "\"voxel-albedo\"",
    "\"voxel-normal\"",
    "\"voxel-emission\"",
    "\"voxel-radiance\"",
    "\"voxel-mip\"",
];

/// The main knobs of each technique (after the frontier in ACCURACY.md).
fn knobs(technique: &str) -> Vec<Knob> {
    use Knob::*;
    let vct = || {
        vec![
            Choice("gi.voxel_resolution", "voxels per side", &["32", "64", "128", "256"]),
            Choice("gi.diffuse_cones", "diffuse cones", &["1", "4", "6", "9", "16"]),
            Choice("gi.bounces", "bounces", &["0", "1", "2", "4"]),
            Toggle("gi.bounce_feedback", "bounce feedback"),
            Choice("gi.downsample", "trace at 1/k", &["1", "2", "4"]),
            Choice("gi.specular", "specular", &["\"cone\"", "\"rt\"", "\"off\""]),
            Choice("gi.shadows", "shadows", &["\"shadow-map\"", "\"cone\"", "\"rt\""]),
            Toggle("gi.ao", "ambient occlusion"),
            Number("gi.step", "cone step", 0.1, 2.0),
        ]
    };
    let rsm = || vec![Choice("gi.rsm_samples", "RSM samples", &["16", "32", "64", "128", "256", "512"])];
    let lpv = || {
        vec![
            Choice("gi.lpv_resolution", "LPV cells", &["8", "16", "32", "64"]),
            Choice("gi.lpv_steps", "LPV steps", &["4", "8", "16", "32"]),
        ]
    };
    let maps = || vec![Choice("gi.rsm_size", "RSM size", &["64", "128", "256", "512"])];
    match technique {
        "\"vct\"" => vct(),
        "\"rsm\"" => [rsm(), maps()].concat(),
        "\"lpv\"" => [lpv(), maps()].concat(),
        "\"rsm+lpv\"" => [rsm(), lpv(), maps()].concat(),
        _ => vec![],
    }
}

/// What the settings panel shows and edits.
pub struct SettingsView<'a> {
    /// The scene's settings as TOML values by dotted key (what the renderer runs with).
    pub value: &'a dyn Fn(&str) -> Option<String>,
    pub schedule: Mode,
    pub preset: Option<Preset>,
    pub camera: CameraMode,
    pub paused: bool,
    pub exposure: f32,
    /// With `render.exposure = "auto"`: the EV it chose (eased), once a frame has run.
    pub auto_exposure: Option<Option<f32>>,
    /// The sky is an image (it can be turned).
    pub image_sky: bool,
}

/// The whole window: settings on the left, timings at the bottom, the frame in the middle.
pub fn layout(
    ui: &mut egui::Ui,
    settings_view: &SettingsView,
    timings_view: &TimingsView,
    notice: Option<&str>,
    frame: (egui::TextureId, (f32, f32)),
    actions: &mut Vec<Action>,
) {
    egui::Panel::left("settings").default_size(250.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| settings(ui, settings_view, actions));
        if let Some(n) = notice {
            ui.colored_label(Color32::from_rgb(230, 120, 90), n);
        }
    });
    egui::Panel::bottom("timings").min_size(150.0).show(ui, |ui| timings(ui, timings_view));
    egui::CentralPanel::default().show(ui, |ui| frame_view(ui, frame, actions));
    keys(ui.ctx(), actions);
}

/// The frame, as large as fits with its aspect; dragging over it turns the camera (right
/// button when flying, left when orbiting), the wheel zooms the orbit.
fn frame_view(ui: &mut egui::Ui, (id, (w, h)): (egui::TextureId, (f32, f32)), actions: &mut Vec<Action>) {
    let avail = ui.available_rect_before_wrap();
    let scale = (avail.width() / w).min(avail.height() / h).max(0.0);
    let rect = Rect::from_center_size(avail.center(), Vec2::new(w * scale, h * scale));
    let r = ui.allocate_rect(avail, Sense::drag());
    let uv = Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0));
    ui.painter().image(id, rect, uv, Color32::WHITE);
    let d = r.drag_delta();
    if d != Vec2::ZERO {
        let radians_per_point = 0.005;
        actions.push(Action::Turn(d.x * radians_per_point, d.y * radians_per_point));
    }
    if r.hovered() {
        let wheel = ui.input(|i| i.smooth_scroll_delta.y);
        if wheel != 0.0 {
            actions.push(Action::Zoom(wheel / 50.0));
        }
    }
}

/// Keys, when no text field has them: WASD/QE fly (Shift faster), R resets the camera, P
/// pauses, F12 captures.
fn keys(ctx: &egui::Context, actions: &mut Vec<Action>) {
    if ctx.egui_wants_keyboard_input() {
        return;
    }
    ctx.input(|i| {
        let axis = |plus: egui::Key, minus: egui::Key| (i.key_down(plus) as i32 - i.key_down(minus) as i32) as f32;
        let m = MoveInput {
            forward: axis(egui::Key::W, egui::Key::S),
            right: axis(egui::Key::D, egui::Key::A),
            up: axis(egui::Key::E, egui::Key::Q),
            fast: i.modifiers.shift,
        };
        if m != MoveInput::default() && m != (MoveInput { fast: true, ..Default::default() }) {
            actions.push(Action::Move(m));
        }
        if i.key_pressed(egui::Key::R) {
            actions.push(Action::ResetCamera);
        }
        if i.key_pressed(egui::Key::P) {
            actions.push(Action::Pause(!actions.contains(&Action::Pause(true))));
        }
        if i.key_pressed(egui::Key::F12) {
            actions.push(Action::Capture);
        }
    });
}

/// The settings panel.
pub fn settings(ui: &mut egui::Ui, v: &SettingsView, actions: &mut Vec<Action>) {
    ui.heading("Settings");
    let technique = (v.value)("gi.mode").unwrap_or_default();
    choice(ui, "technique", "gi.mode", &technique, TECHNIQUES, actions);
    schedule(ui, v.schedule, actions);
    preset(ui, v.preset, actions);
    ui.separator();
    for knob in knobs(&technique) {
        knob_ui(ui, &knob, v, actions);
    }
    if technique == "\"vct\"" && (v.value)("gi.specular").as_deref() == Some("\"rt\"") {
        knob_ui(ui, &Knob::Choice("gi.specular_rays", "rays per pixel", &["1", "4", "16", "64"]), v, actions);
        knob_ui(ui, &Knob::Choice("gi.specular_history", "frames averaged", &["1", "4", "16", "64"]), v, actions);
    }
    ui.separator();
    let view = (v.value)("render.view").unwrap_or_default();
    choice(ui, "view", "render.view", &view, VIEWS, actions);
    if view == "\"voxel-mip\"" {
        knob_ui(ui, &Knob::Number("render.view_lod", "mip level", 0.0, 8.0), v, actions);
    }
    exposure(ui, v, actions);
    sky(ui, v, actions);
    ui.separator();
    camera(ui, v, actions);
}

/// The sky's brightness and, for an image sky, its turn (a scene without a sky has neither).
fn sky(ui: &mut egui::Ui, v: &SettingsView, actions: &mut Vec<Action>) {
    if (v.value)("sky.scale").is_none() {
        return;
    }
    ui.separator();
    knob_ui(ui, &Knob::Number("sky.scale", "sky scale", 0.0, 8.0), v, actions);
    if v.image_sky {
        knob_ui(ui, &Knob::Number("sky.rotation", "sky turn (degrees)", -180.0, 180.0), v, actions);
    }
}

/// The exposure: "auto" (GPU, eased; the EV it chose shown beside it) or a slider in EV; the
/// slider starts from what "auto" chose.
fn exposure(ui: &mut egui::Ui, v: &SettingsView, actions: &mut Vec<Action>) {
    let chosen = v.auto_exposure.flatten();
    let mut auto = v.auto_exposure.is_some();
    ui.horizontal(|ui| {
        if ui.checkbox(&mut auto, "auto exposure").changed() {
            let value = if auto { "\"auto\"".to_string() } else { format!("{:?}", v.exposure + chosen.unwrap_or(0.0)) };
            actions.push(Action::Set("render.exposure".into(), value));
        }
        if let Some(ev) = chosen {
            ui.label(format!("{:+.2} EV", v.exposure + ev));
        }
    });
    let mut ev = v.exposure + chosen.unwrap_or(0.0);
    if ui.add(egui::Slider::new(&mut ev, -8.0..=8.0).text("exposure (EV)")).changed() {
        actions.push(Action::Set("render.exposure".into(), format!("{ev:?}")));
    }
}

fn knob_ui(ui: &mut egui::Ui, knob: &Knob, v: &SettingsView, actions: &mut Vec<Action>) {
    match *knob {
        Knob::Choice(key, label, options) => {
            let current = (v.value)(key).unwrap_or_default();
            choice(ui, label, key, &current, options, actions);
        }
        Knob::Toggle(key, label) => {
            let mut on = (v.value)(key).as_deref() == Some("true");
            if ui.checkbox(&mut on, label).changed() {
                actions.push(Action::Set(key.into(), on.to_string()));
            }
        }
        Knob::Number(key, label, lo, hi) => {
            let mut x = (v.value)(key).and_then(|s| s.parse::<f32>().ok()).unwrap_or(lo);
            let r = ui.add(egui::Slider::new(&mut x, lo..=hi).text(label));
            // Rebuilds only when the drag ends, not at every step.
            if r.drag_stopped() || (r.changed() && !r.dragged()) {
                actions.push(Action::Set(key.into(), format!("{x:?}")));
            }
        }
    }
}

/// A combo box over TOML values, shown without their quotes.
fn choice(ui: &mut egui::Ui, label: &str, key: &str, current: &str, options: &[&str], actions: &mut Vec<Action>) {
    let shown = |s: &str| s.trim_matches('"').to_string();
    egui::ComboBox::from_label(label).selected_text(shown(current)).show_ui(ui, |ui| {
        for o in options {
            if ui.selectable_label(current == *o, shown(o)).clicked() && current != *o {
                actions.push(Action::Set(key.into(), o.to_string()));
            }
        }
    });
}

fn schedule(ui: &mut egui::Ui, mode: Mode, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        ui.label("schedule");
        for m in Mode::ALL {
            if ui.selectable_label(mode == m, m.name()).clicked() && mode != m {
                actions.push(Action::Schedule(m));
            }
        }
    });
}

fn preset(ui: &mut egui::Ui, current: Option<Preset>, actions: &mut Vec<Action>) {
    let name = |p: Option<Preset>| p.map(|p| format!("{p:?}").to_lowercase()).unwrap_or_else(|| "scene file".into());
    egui::ComboBox::from_label("preset").selected_text(name(current)).show_ui(ui, |ui| {
        let presets = <Preset as clap::ValueEnum>::value_variants().iter().copied().map(Some);
        for p in std::iter::once(None).chain(presets) {
            if ui.selectable_label(current == p, name(p)).clicked() && current != p {
                actions.push(Action::Preset(p));
            }
        }
    });
}

fn camera(ui: &mut egui::Ui, v: &SettingsView, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        ui.label("camera");
        for (m, name) in [(CameraMode::Fly, "fly"), (CameraMode::Orbit, "orbit")] {
            if ui.selectable_label(v.camera == m, name).clicked() && v.camera != m {
                actions.push(Action::CameraMode(m));
            }
        }
        if ui.button("reset (R)").clicked() {
            actions.push(Action::ResetCamera);
        }
    });
    ui.horizontal(|ui| {
        let mut paused = v.paused;
        if ui.checkbox(&mut paused, "pause time (P)").changed() {
            actions.push(Action::Pause(paused));
        }
        if ui.button("capture (F12)").clicked() {
            actions.push(Action::Capture);
        }
    });
    ui.small("WASD fly, Q/E down/up, Shift faster; drag over the frame to look (fly) or go round (orbit); wheel zooms the orbit");
}

/// Host and GPU time of the frames of the last seconds.
pub struct FrameTimes {
    /// (host ms, GPU span ms) per frame, oldest first.
    pub frames: VecDeque<(f64, f64)>,
}

impl FrameTimes {
    pub const KEEP: usize = 300;

    pub fn push(&mut self, host_ms: f64, gpu_ms: f64) {
        if self.frames.len() == Self::KEEP {
            self.frames.pop_front();
        }
        self.frames.push_back((host_ms, gpu_ms));
    }
}

/// What the timings panel shows.
pub struct TimingsView<'a> {
    pub device: &'a str,
    pub last: Option<&'a FrameTiming>,
    pub times: &'a FrameTimes,
    pub present_mode: &'a str,
    pub size: (u32, u32),
}

/// The timings panel: the last frame's passes per queue, then the frame-time graph.
pub fn timings(ui: &mut egui::Ui, v: &TimingsView) {
    let (host, gpu) = v.times.frames.back().copied().unwrap_or_default();
    ui.horizontal(|ui| {
        ui.strong(v.device);
        ui.label(format!(
            "{}x{}  |  frame {host:.2} ms wall clock, {gpu:.2} ms GPU timestamps  |  present {}",
            v.size.0, v.size.1, v.present_mode
        ));
    });
    match v.last {
        Some(t) => timeline(ui, t),
        None => {
            ui.label("(no timestamps: this device's queues have none)");
        }
    }
    graph(ui, v.times);
}

/// Lane colours: graphics blue, compute orange (as `bench --timeline`).
fn lane_color(q: QueueKind) -> Color32 {
    match q {
        QueueKind::Graphics => Color32::from_rgb(70, 130, 200),
        QueueKind::Compute => Color32::from_rgb(230, 140, 50),
    }
}

/// One lane per queue, each pass a bar from its first to its last timestamp; hovering names it.
fn timeline(ui: &mut egui::Ui, t: &FrameTiming) {
    let begin = t.passes.iter().map(|p| p.begin_ms).fold(f64::INFINITY, f64::min);
    let span = t.gpu_span_ms().max(1e-6);
    let lane_h = 18.0;
    let (rect, resp) = ui.allocate_exact_size(Vec2::new(ui.available_width(), 2.0 * lane_h + 4.0), Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_gray(24));
    let x = |ms: f64| rect.left() + ((ms - begin) / span) as f32 * rect.width();
    let mut hovered = None;
    for p in &t.passes {
        let y = rect.top() + 2.0 + p.queue.index() as f32 * lane_h;
        let r = Rect::from_min_max(
            Pos2::new(x(p.begin_ms), y),
            Pos2::new(x(p.end_ms).max(x(p.begin_ms) + 1.0), y + lane_h - 2.0),
        );
        painter.rect_filled(r, 1.0, lane_color(p.queue));
        let font = egui::FontId::proportional(11.0);
        let name = painter.layout_no_wrap(p.name.clone(), font, Color32::BLACK);
        if name.size().x + 4.0 < r.width() {
            painter.galley(Pos2::new(r.left() + 2.0, r.center().y - name.size().y / 2.0), name, Color32::BLACK);
        }
        if resp.hover_pos().is_some_and(|h| r.contains(h)) {
            hovered = Some(p);
        }
    }
    let label = match hovered {
        Some(p) => format!("{} ({}): {:.3} ms", p.name, p.queue.name(), p.gpu_ms()),
        None => format!("last frame: {span:.2} ms GPU; graphics above, compute below; hover a pass"),
    };
    ui.small(label);
}

/// Wall-clock (white) and GPU (green) frame times of the last frames, scaled to the slowest.
fn graph(ui: &mut egui::Ui, times: &FrameTimes) {
    let (rect, _) = ui.allocate_exact_size(Vec2::new(ui.available_width(), 60.0), Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_gray(24));
    let max = times.frames.iter().map(|(h, g)| h.max(*g)).fold(1e-3, f64::max);
    let n = FrameTimes::KEEP as f32;
    let point = |i: usize, ms: f64| {
        Pos2::new(rect.left() + i as f32 / n * rect.width(), rect.bottom() - (ms / max) as f32 * rect.height())
    };
    for (which, color) in [(0, Color32::WHITE), (1, Color32::from_rgb(90, 200, 90))] {
        let pts: Vec<Pos2> =
            times.frames.iter().enumerate().map(|(i, f)| point(i, if which == 0 { f.0 } else { f.1 })).collect();
        painter.add(egui::Shape::line(pts, Stroke::new(1.0, color)));
    }
    ui.small(format!(
        "frame time, last {} frames (white wall clock, green GPU span); top = {max:.1} ms",
        times.frames.len()
    ));
}
