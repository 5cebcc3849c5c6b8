//! See `dvsgi_fuzz::scene_toml`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    dvsgi_fuzz::scene_toml(dvsgi_fuzz::workdir(), data);
});
