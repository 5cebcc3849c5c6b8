//! What a frame reuses from the frames before it. The voxels are voxelized and lit only when
//! the update policy or the lights say so (`Renderer::frame_state`); the shadow maps and the
//! reflective shadow maps (with the light propagation volume built from them) are redrawn only
//! where what they are drawn from changed: a light, a view, or a caster's transform. The
//! G-buffer and everything after it are camera-dependent and run every frame.
//!
//! Everything here is host-side bookkeeping of what the GPU images hold, tested without a GPU.

use crate::render::lights::GpuShadowView;
use std::sync::{Arc, Mutex};

/// Per view: the view the cache of the static casters holds, if it holds one (only with
/// moving casters, and only for views that stood still while the casters moved). One cache
/// serves every copy of the frame's maps (`async-pipelined`): the copies share this.
pub type CacheHeld = Arc<Mutex<Vec<Option<GpuShadowView>>>>;

/// What the shadow maps and the static casters' cache were drawn from, view by view.
#[derive(Debug, Default)]
pub struct ShadowCache {
    /// Per view: the view (matrix and parameters) the maps hold; `None` before the first draw.
    maps: Vec<Option<GpuShadowView>>,
    /// What the static casters' cache holds, shared by every copy of the maps.
    cache: CacheHeld,
    /// The instance rows of the static and of the moving casters the maps were drawn with;
    /// `None` before the first draw.
    instances: Option<(Vec<u8>, Vec<u8>)>,
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
    /// The draws that bring the maps to `views` with the static casters placed by `statics`
    /// and the moving ones by `moving` (their rows of the instance table; `moving` is empty
    /// where nothing moves), recorded as done: call it only for a frame that records them. A
    /// static caster whose transform was edited between frames redraws every view from
    /// scratch and empties the cache.
    pub fn plan(&mut self, views: &[GpuShadowView], statics: &[u8], moving: &[u8]) -> ShadowDraws {
        let n = views.len();
        self.maps.resize(n, None);
        let mut cache = self.cache.lock().unwrap_or_else(|p| p.into_inner());
        cache.resize(n, None);
        let held = self.instances.replace((statics.to_vec(), moving.to_vec()));
        let edited = held.as_ref().is_some_and(|h| h.0 != statics);
        let moved = held.as_ref().is_some_and(|h| h.1 != moving);
        if edited {
            cache.iter_mut().for_each(|c| *c = None);
        }
        let mut draws = ShadowDraws::default();
        for (i, view) in views.iter().enumerate() {
            if !same(&self.maps[i], view) || edited {
                draws.all.push(i as u32);
                self.maps[i] = Some(*view);
            } else if moved {
                if !same(&cache[i], view) {
                    draws.statics.push(i as u32);
                    cache[i] = Some(*view);
                }
                draws.moving.push(i as u32);
            }
        }
        draws
    }
}

impl ShadowCache {
    /// Bookkeeping for one copy of the maps whose static casters' cache is `cache`'s.
    pub fn sharing(cache: &CacheHeld) -> ShadowCache {
        ShadowCache { cache: cache.clone(), ..ShadowCache::default() }
    }

    /// Forget what the maps and the cache hold: the next plan draws every view.
    pub fn forget(&mut self) {
        self.cache.lock().unwrap_or_else(|p| p.into_inner()).clear();
        *self = ShadowCache::sharing(&self.cache);
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
        assert_eq!(c.plan(&views, &[1], &[]), draws(&[0, 1, 2], &[], &[]), "the first frame draws every view");
        assert_eq!(c.plan(&views, &[1], &[]), ShadowDraws::default());
        // A camera-fitted cascade moved: only it is drawn.
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], &[1], &[]), draws(&[0], &[], &[]));
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], &[1], &[]), ShadowDraws::default());
        // A transform edited between frames, in a scene without motion: every view again.
        assert_eq!(c.plan(&[view(1.5), view(2.0), view(3.0)], &[2], &[]), draws(&[0, 1, 2], &[], &[]));
    }

    #[test]
    fn moving_casters_are_drawn_over_the_cached_static_casters() {
        let mut c = ShadowCache::default();
        let views = [view(1.0), view(2.0)];
        assert_eq!(c.plan(&views, &[1, 2], &[3, 4]), draws(&[0, 1], &[], &[]), "every caster, every view");
        assert_eq!(c.plan(&views, &[1, 2], &[3, 4]), ShadowDraws::default(), "nothing moved");
        // The casters moved: the static ones are cached, the copy gets the moving ones.
        assert_eq!(c.plan(&views, &[1, 2], &[3, 5]), draws(&[], &[0, 1], &[0, 1]));
        // From then on only the moving casters are drawn.
        assert_eq!(c.plan(&views, &[1, 2], &[3, 6]), draws(&[], &[], &[0, 1]));
        // A view changed (its light moved) as the casters moved: it is drawn from scratch,
        // and the other gets the moving casters over its cache.
        let turned = [view(1.0), view(9.0)];
        assert_eq!(c.plan(&turned, &[1, 2], &[3, 7]), draws(&[1], &[], &[0]));
        // It stands still now: its cache is drawn again before the moving casters go over it.
        assert_eq!(c.plan(&turned, &[1, 2], &[3, 8]), draws(&[], &[1], &[0, 1]));
        // A view that changes every frame is drawn from scratch every frame, never cached.
        for k in 0..3 {
            let light = [view(1.0), view(10.0 + k as f32)];
            assert_eq!(c.plan(&light, &[1, 2], &[4, k]), draws(&[1], &[], &[0]));
        }
        // A static caster's transform edited: every view from scratch, and the cache is drawn
        // again once the casters move.
        let still = [view(1.0), view(12.0)];
        assert_eq!(c.plan(&still, &[1, 9], &[4, 2]), draws(&[0, 1], &[], &[]));
        assert_eq!(c.plan(&still, &[1, 9], &[4, 3]), draws(&[], &[0, 1], &[0, 1]));
    }

    /// async-pipelined: two copies of the maps, used in turn, share one static casters' cache.
    /// A view that comes to stand still has its static casters drawn once, by whichever copy
    /// sees it first; the other copy, whose maps last held another view, draws it from scratch.
    #[test]
    fn copies_of_the_maps_share_the_static_casters_cache() {
        let (mut a, cache) = (ShadowCache::default(), CacheHeld::default());
        a = ShadowCache { cache: cache.clone(), ..a };
        let mut b = ShadowCache::sharing(&cache);
        let (v1, v2) = ([view(1.0)], [view(2.0)]);
        assert_eq!(a.plan(&v1, &[1], &[3]), draws(&[0], &[], &[]));
        assert_eq!(b.plan(&v2, &[1], &[4]), draws(&[0], &[], &[]));
        // v2 stands still from here on while the casters move.
        assert_eq!(a.plan(&v2, &[1], &[5]), draws(&[0], &[], &[]), "a's maps hold v1");
        assert_eq!(b.plan(&v2, &[1], &[6]), draws(&[], &[0], &[0]), "b caches v2's static casters");
        assert_eq!(a.plan(&v2, &[1], &[7]), draws(&[], &[], &[0]), "a copies the cache b drew");
        assert_eq!(b.plan(&v2, &[1], &[8]), draws(&[], &[], &[0]));
        // Forgetting (a redraw) empties the shared cache too.
        a.forget();
        b.forget();
        assert_eq!(a.plan(&v2, &[1], &[9]), draws(&[0], &[], &[]));
        assert_eq!(b.plan(&v2, &[1], &[10]), draws(&[0], &[], &[]));
        assert_eq!(a.plan(&v2, &[1], &[11]), draws(&[], &[0], &[0]));
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
