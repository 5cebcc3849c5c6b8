//! See `dvsgi_fuzz::obj_mtl`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    dvsgi_fuzz::obj_mtl(dvsgi_fuzz::workdir(), data);
});
