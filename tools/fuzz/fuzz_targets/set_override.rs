//! See `dvsgi_fuzz::set_override`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    dvsgi_fuzz::set_override(dvsgi_fuzz::workdir(), data);
});
