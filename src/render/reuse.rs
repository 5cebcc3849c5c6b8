//! What a frame reuses from the frames before it. The voxels are voxelized and lit only when
//! the update policy or the lights say so (`Renderer::frame_state`); the shadow maps and the
//! reflective shadow maps (with the light propagation volume built from them) are redrawn only
//! where what they are drawn from changed: a light, a view, or a caster's transform. The
//! G-buffer and everything after it are camera-dependent and run every frame.
//!
//! Everything here is host-side bookkeeping of what the GPU images hold, tested without a GPU.

use crate::render::lights::GpuShadowView;

/// What the shadow maps were drawn from, view by view.
#[derive(Debug, Default)]
pub struct ShadowCache {
    /// Per view: the view (matrix and parameters) the static casters were drawn with (every
    /// caster where none moves); `None` before the first draw.
    views: Vec<Option<GpuShadowView>>,
    /// The instance table the moving casters were drawn with; `None` before the first draw.
    instances: Option<Vec<u8>>,
}

/// The views a frame draws.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct ShadowDraws {
    /// Views whose static casters are drawn (into the cache; every caster into the maps where
    /// no caster moves): the views that changed.
    pub statics: Vec<u32>,
    /// Views the cache is copied into and the moving casters drawn over: every view when the
    /// moving casters moved, else the views that changed. Empty without moving casters.
    pub moving: Vec<u32>,
}

fn same(a: &GpuShadowView, b: &GpuShadowView) -> bool {
    bytemuck::bytes_of(a) == bytemuck::bytes_of(b)
}

impl ShadowCache {
    /// The draws that bring the maps to `views` with the casters placed by `instances` (the
    /// instance table; `None` where no caster moves), recorded as done: call it only for a
    /// frame that records them.
    pub fn plan(&mut self, views: &[GpuShadowView], instances: Option<&[u8]>) -> ShadowDraws {
        self.views.resize(views.len(), None);
        let statics: Vec<u32> = (0..views.len())
            .filter(|&i| !self.views[i].is_some_and(|held| same(&held, &views[i])))
            .map(|i| i as u32)
            .collect();
        for &i in &statics {
            self.views[i as usize] = Some(views[i as usize]);
        }
        let moving = match instances {
            None => Vec::new(),
            Some(now) if self.instances.as_deref() != Some(now) => {
                self.instances = Some(now.to_vec());
                (0..views.len() as u32).collect()
            }
            Some(_) => statics.clone(),
        };
        ShadowDraws { statics, moving }
    }
}

/// What a pass's output was made from, as bytes: the pass runs again only when they change.
#[derive(Debug, Default)]
pub struct InputsSeen(Option<Vec<u8>>);

impl InputsSeen {
    /// Whether `inputs` differ from those last seen (always on the first call); remembers them.
    pub fn changed(&mut self, inputs: &[u8]) -> bool {
        if self.0.as_deref() == Some(inputs) {
            return false;
        }
        self.0 = Some(inputs.to_vec());
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(x: f32) -> GpuShadowView {
        GpuShadowView { view_proj: [[x; 4]; 4], params: [1.0, 1.0, 0.0, 0.0] }
    }

    #[test]
    fn without_moving_casters_only_the_views_that_changed_are_drawn() {
        let mut c = ShadowCache::default();
        let all = ShadowDraws { statics: vec![0, 1, 2], moving: vec![] };
        assert_eq!(c.plan(&[view(1.0), view(2.0), view(3.0)], None), all, "the first frame draws every view");
        assert_eq!(c.plan(&[view(1.0), view(2.0), view(3.0)], None), ShadowDraws::default());
        // A camera-fitted cascade moved: only it is drawn.
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], None).statics, [0]);
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], None), ShadowDraws::default());
    }

    #[test]
    fn moving_casters_are_drawn_over_every_view_when_they_move() {
        let mut c = ShadowCache::default();
        let views = [view(1.0), view(2.0)];
        let first = c.plan(&views, Some(&[1, 2, 3, 4]));
        assert_eq!(first, ShadowDraws { statics: vec![0, 1], moving: vec![0, 1] });
        assert_eq!(c.plan(&views, Some(&[1, 2, 3, 4])), ShadowDraws::default(), "nothing moved");
        // The casters moved: the static maps are reused, every view gets the copy and the
        // moving casters.
        assert_eq!(c.plan(&views, Some(&[1, 2, 3, 5])), ShadowDraws { statics: vec![], moving: vec![0, 1] });
        // A view changed and nothing moved: that view only, both layers.
        assert_eq!(
            c.plan(&[view(1.0), view(9.0)], Some(&[1, 2, 3, 5])),
            ShadowDraws { statics: vec![1], moving: vec![1] }
        );
    }

    #[test]
    fn inputs_seen_change_once() {
        let mut seen = InputsSeen::default();
        assert!(seen.changed(&[1, 2]));
        assert!(!seen.changed(&[1, 2]));
        assert!(seen.changed(&[1, 3]));
        assert!(seen.changed(&[]) && !seen.changed(&[]));
    }
}
