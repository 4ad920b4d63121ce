//! Detector model files: our JSON (geometry validated), OpenCV `.npy` vectors and `HOGDescriptor`
//! YAML, and plain number lists. The first byte picks the format.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mosaicd::detect::{Domain, LinearModel};
use mosaicd::npy::NpyArray;

fuzz_target!(|data: &[u8]| {
    let Some((&which, body)) = data.split_first() else {
        return;
    };
    match which % 4 {
        0 => {
            if let Ok(text) = std::str::from_utf8(body) {
                if let Ok(m) = LinearModel::from_json(text, "fuzz.json") {
                    // A model that validates has a spec whose descriptor length is its weights'.
                    let spec = m.hog_spec("fuzz.json").expect("validated model");
                    assert_eq!(spec.descriptor_len(), m.weights.len());
                }
            }
        }
        1 => {
            if let Ok(a) = NpyArray::parse(body, "fuzz.npy") {
                let v: Vec<f32> = a.data.iter().map(|&x| x as f32).collect();
                let _ = LinearModel::from_opencv_vector(&v, Domain::Grey, "fuzz.npy");
            }
        }
        2 => {
            if let Ok(text) = std::str::from_utf8(body) {
                let _ = LinearModel::from_opencv_yaml(text, Domain::Grey, "fuzz.yml");
            }
        }
        _ => {
            let path = mosaicd_fuzz::scratch_file("in.txt", body);
            let _ = LinearModel::load(&path, Domain::Grey);
        }
    }
});
