//! Quality presets (`--preset`): points on the measured speed/accuracy frontier of the
//! Cornell box and Sponza on lavapipe (ACCURACY.md says how each was chosen and what it
//! costs and scores). A preset sets `[gi]` keys; `--set` overrides still apply after it.

/// A named set of `[gi]` settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    Low,
    Medium,
    High,
    Ultra,
}

impl Preset {
    /// The `[gi]` overrides, as (dotted key, TOML value).
    pub fn overrides(self) -> Vec<(String, String)> {
        // (cones, aperture, bounces): all at 32^3 voxels, step 1, downsample 2, AO off, which
        // every measured front preferred (ACCURACY.md).
        let (cones, aperture, bounces) = match self {
            Preset::Low => ("4", "0", "0"),
            Preset::Medium => ("9", "0", "0"),
            Preset::High => ("4", "60", "1"),
            Preset::Ultra => ("9", "0", "1"),
        };
        let values: [(&str, &str); 7] = [
            ("voxel_resolution", "32"),
            ("diffuse_cones", cones),
            ("diffuse_cone_angle", aperture),
            ("step", "1"),
            ("bounces", bounces),
            ("downsample", "2"),
            ("ao", "false"),
        ];
        let mut out = vec![("gi.mode".to_string(), "\"vct\"".to_string())];
        out.extend(values.iter().map(|(k, v)| (format!("gi.{k}"), v.to_string())));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    #[test]
    fn every_preset_is_a_valid_gi_table_and_they_rise_in_cost() {
        let mut last = (0, 0);
        for p in Preset::value_variants() {
            let mut table = toml::Table::new();
            for (k, v) in p.overrides() {
                let key = k.strip_prefix("gi.").unwrap().to_string();
                let value: toml::Value = toml::from_str::<toml::Table>(&format!("x = {v}")).unwrap()["x"].clone();
                table.insert(key, value);
            }
            let gi: crate::scene::GiSettings = table.try_into().expect("preset keys are [gi] keys");
            gi.validate().unwrap_or_else(|(k, m)| panic!("{p:?}: gi.{k}: {m}"));
            // Each level costs more: more bounces, or as many and more cones.
            let cost = (gi.bounces, gi.diffuse_cones);
            assert!(cost > last, "{p:?}");
            last = cost;
        }
    }
}
