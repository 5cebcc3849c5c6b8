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
        let values: &[(&str, &str)] = match self {
            Preset::Low => &[
                ("voxel_resolution", "32"),
                ("diffuse_cones", "4"),
                ("diffuse_cone_angle", "0"),
                ("step", "1"),
                ("bounces", "0"),
                ("downsample", "2"),
            ],
            Preset::Medium => &[
                ("voxel_resolution", "64"),
                ("diffuse_cones", "4"),
                ("diffuse_cone_angle", "0"),
                ("step", "1"),
                ("bounces", "1"),
                ("downsample", "2"),
            ],
            Preset::High => &[
                ("voxel_resolution", "64"),
                ("diffuse_cones", "9"),
                ("diffuse_cone_angle", "0"),
                ("step", "0.5"),
                ("bounces", "1"),
                ("downsample", "1"),
            ],
            Preset::Ultra => &[
                ("voxel_resolution", "128"),
                ("diffuse_cones", "9"),
                ("diffuse_cone_angle", "0"),
                ("step", "0.5"),
                ("bounces", "2"),
                ("downsample", "1"),
            ],
        };
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
        let mut last_res = 0;
        for p in Preset::value_variants() {
            let mut table = toml::Table::new();
            for (k, v) in p.overrides() {
                let key = k.strip_prefix("gi.").unwrap().to_string();
                let value: toml::Value = toml::from_str::<toml::Table>(&format!("x = {v}")).unwrap()["x"].clone();
                table.insert(key, value);
            }
            let gi: crate::scene::GiSettings = table.try_into().expect("preset keys are [gi] keys");
            gi.validate().unwrap_or_else(|(k, m)| panic!("{p:?}: gi.{k}: {m}"));
            assert!(gi.voxel_resolution >= last_res, "{p:?}");
            last_res = gi.voxel_resolution;
        }
    }
}
