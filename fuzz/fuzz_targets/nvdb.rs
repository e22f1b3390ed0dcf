//! Fuzzes the .nvdb loader: no input may panic, abort, hang or allocate without bound.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| common::load(data, "nvdb"));
