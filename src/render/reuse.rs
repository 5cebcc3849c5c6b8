//! What a frame reuses from the frames before it. The voxels are voxelized and lit only when
//! the update policy or the lights say so (`Renderer::frame_state`); the shadow maps and the
//! reflective shadow maps (with the light propagation volume built from them) are redrawn only
//! where what they are drawn from changed: a light, a view, or a caster's transform. The
//! G-buffer and everything after it are camera-dependent and run every frame.
//!
//! Everything here is host-side bookkeeping of what the GPU images hold, tested without a GPU.

use crate::render::lights::GpuShadowView;

/// What the shadow maps and the static casters' cache were drawn from, view by view.
#[derive(Debug, Default)]
pub struct ShadowCache {
    /// Per view: the view (matrix and parameters) the maps hold; `None` before the first draw.
    maps: Vec<Option<GpuShadowView>>,
    /// Per view: the view the cache of the static casters holds, if it holds one (only with
    /// moving casters, and only for views that stood still while the casters moved).
    cache: Vec<Option<GpuShadowView>>,
    /// The instance table the moving casters were drawn with; `None` before the first draw.
    instances: Option<Vec<u8>>,
}

/// The views a frame draws.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct ShadowDraws {
    /// Views drawn from scratch with every caster: the views that changed. A view that
    /// changes every frame (a moving light's) costs what it did without a cache.
    pub all: Vec<u32>,
    /// Views whose static casters are drawn into the cache: views that stand still while the
    /// moving casters move, and that the cache does not hold yet.
    pub statics: Vec<u32>,
    /// Views the cache is copied into and the moving casters drawn over: the views that stand
    /// still while the moving casters move.
    pub moving: Vec<u32>,
}

fn same(a: &Option<GpuShadowView>, b: &GpuShadowView) -> bool {
    a.is_some_and(|a| bytemuck::bytes_of(&a) == bytemuck::bytes_of(b))
}

impl ShadowCache {
    /// The draws that bring the maps to `views` with the casters placed by `instances` (the
    /// instance table; `None` where no caster moves), recorded as done: call it only for a
    /// frame that records them.
    pub fn plan(&mut self, views: &[GpuShadowView], instances: Option<&[u8]>) -> ShadowDraws {
        let n = views.len();
        self.maps.resize(n, None);
        self.cache.resize(n, None);
        let mut draws = ShadowDraws::default();
        let moved = instances.is_some_and(|now| self.instances.as_deref() != Some(now));
        for (i, view) in views.iter().enumerate() {
            if !same(&self.maps[i], view) {
                draws.all.push(i as u32);
                self.maps[i] = Some(*view);
            } else if moved {
                if !same(&self.cache[i], view) {
                    draws.statics.push(i as u32);
                    self.cache[i] = Some(*view);
                }
                draws.moving.push(i as u32);
            }
        }
        if let Some(now) = instances {
            self.instances = Some(now.to_vec());
        }
        draws
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

    fn draws(all: &[u32], statics: &[u32], moving: &[u32]) -> ShadowDraws {
        ShadowDraws { all: all.to_vec(), statics: statics.to_vec(), moving: moving.to_vec() }
    }

    #[test]
    fn without_moving_casters_only_the_views_that_changed_are_drawn() {
        let mut c = ShadowCache::default();
        let views = [view(1.0), view(2.0), view(3.0)];
        assert_eq!(c.plan(&views, None), draws(&[0, 1, 2], &[], &[]), "the first frame draws every view");
        assert_eq!(c.plan(&views, None), ShadowDraws::default());
        // A camera-fitted cascade moved: only it is drawn.
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], None), draws(&[0], &[], &[]));
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], None), ShadowDraws::default());
    }

    #[test]
    fn moving_casters_are_drawn_over_the_cached_static_casters() {
        let mut c = ShadowCache::default();
        let views = [view(1.0), view(2.0)];
        assert_eq!(c.plan(&views, Some(&[1, 2, 3, 4])), draws(&[0, 1], &[], &[]), "every caster, every view");
        assert_eq!(c.plan(&views, Some(&[1, 2, 3, 4])), ShadowDraws::default(), "nothing moved");
        // The casters moved: the static ones are cached, the copy gets the moving ones.
        assert_eq!(c.plan(&views, Some(&[1, 2, 3, 5])), draws(&[], &[0, 1], &[0, 1]));
        // From then on only the moving casters are drawn.
        assert_eq!(c.plan(&views, Some(&[1, 2, 3, 6])), draws(&[], &[], &[0, 1]));
        // A view changed (its light moved) as the casters moved: it is drawn from scratch,
        // and the other gets the moving casters over its cache.
        let turned = [view(1.0), view(9.0)];
        assert_eq!(c.plan(&turned, Some(&[1, 2, 3, 7])), draws(&[1], &[], &[0]));
        // It stands still now: its cache is drawn again before the moving casters go over it.
        assert_eq!(c.plan(&turned, Some(&[1, 2, 3, 8])), draws(&[], &[1], &[0, 1]));
        // A view that changes every frame is drawn from scratch every frame, never cached.
        for k in 0..3 {
            let light = [view(1.0), view(10.0 + k as f32)];
            assert_eq!(c.plan(&light, Some(&[1, 2, 4, k])), draws(&[1], &[], &[0]));
        }
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
