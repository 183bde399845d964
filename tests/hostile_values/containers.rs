//! Generated cases for what headers say about the data: NIfTI series, vector data and scalings,
//! trailing bytes, volumes without a finite value, data declared compressed that is not.

use super::*;

pub(super) fn nifti_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let both = |cases: &mut Vec<Case>, name: &str, bytes: Vec<u8>, expect: &dyn Fn() -> Expect| {
        cases.push(case(format!("{name}.nii"), bytes.clone(), expect()));
        cases.push(case(format!("{name}.nii.gz"), gzip(&bytes), expect()));
    };
    for (index, size) in [(4, 2), (4, 3), (4, 100), (5, 2), (5, 3), (6, 2), (7, 5)] {
        let bytes = nifti(|h| {
            set_i16(h, 40, index as i16);
            set_i16(h, 40 + 2 * index, size);
        });
        let what = if index == 5 {
            "vector or multi-component data (only one scalar per voxel is read)"
        } else {
            "series of volumes (only one 3-D volume is read)"
        };
        let words = format!("unsupported NIfTI {what} 'dim[{index}] = {size}'");
        both(&mut cases, &format!("dim{index}-{size}"), bytes, &|| error(words.clone()));
    }
    let one_volume = nifti(|h| {
        set_i16(h, 40, 5);
        set_i16(h, 48, 1);
        set_i16(h, 50, 1);
    });
    both(&mut cases, "dim4-1-dim5-1", one_volume, &|| opens(RANGE, ONE_MM));
    for (datatype, bitpix) in [(128, 24), (2304, 32)] {
        let bytes = nifti(|h| {
            set_i16(h, 70, datatype);
            set_i16(h, 72, bitpix);
        });
        both(&mut cases, &format!("colour-{datatype}"), bytes, &|| error("colour datatype"));
    }
    let scaled = |slope: f32, intercept: f32| {
        nifti(|h| {
            set_f32(h, 112, slope);
            set_f32(h, 116, intercept);
        })
    };
    for (slope, intercept, words) in [
        (f32::INFINITY, 0.0, "'scl_slope' is invalid: inf"),
        (f32::NEG_INFINITY, -1024.0, "'scl_slope' is invalid: -inf"),
        (2.0, f32::NAN, "'scl_inter' is invalid: NaN"),
        (1.0, f32::INFINITY, "'scl_inter' is invalid: inf"),
        (1e38, 0.0, "beyond the range of 32-bit floats"),
        (-1e37, 0.0, "after the file's value scaling"),
        (3e35, 3e38, "beyond the range of 32-bit floats"),
    ] {
        both(&mut cases, &format!("scale-{slope}-{intercept}"), scaled(slope, intercept), &|| error(words));
    }
    for (slope, intercept, range, warning) in [
        (2.0, -1024.0, [-2924.0, 1076.0], None),
        (0.0, 0.0, RANGE, None),
        (f32::NAN, f32::NAN, RANGE, None),
        (f32::NAN, 0.0, RANGE, None),
        (f32::NAN, -1024.0, RANGE, Some("scl_inter -1024 is not applied")),
        (0.0, 5.0, RANGE, Some("scl_inter 5 is not applied")),
    ] {
        let expect = || Expect::Opens { range, spacing_mm: ONE_MM, warning };
        both(&mut cases, &format!("scale-{slope}-{intercept}"), scaled(slope, intercept), &expect);
    }
    cases
}

/// Bytes after the data, one rule in every format: refused, naming what the header promises.
pub(super) fn trailing_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let promises = "more than the 16 bytes the header promises";
    for extra in [1usize, 2, 1000] {
        let tail = vec![0x55u8; extra];
        cases.push(case(format!("tail-{extra}.nii"), [nifti(|_| {}), tail.clone()].concat(), error(promises)));
        cases.push(case(
            format!("tail-{extra}.nii.gz"),
            gzip(&[nifti(|_| {}), tail.clone()].concat()),
            error(promises),
        ));
        cases.push(case(format!("tail-{extra}.nrrd"), [nrrd("", "raw"), tail.clone()].concat(), error(promises)));
        let gzip_nrrd = nrrd_over("", "gzip", &gzip(&[little(&VALUES), tail.clone()].concat()));
        cases.push(case(format!("tail-{extra}.gz.nrrd"), gzip_nrrd, error(promises)));
        let detached = nrrd_over("data file: data.raw\n", "raw", &[]);
        cases.push(Case {
            detached: Some([little(&VALUES), tail.clone()].concat()),
            ..case(format!("tail-{extra}.nhdr"), detached, error(promises))
        });
        let mha = metaimage("", &[little(&VALUES), tail.clone()].concat());
        cases.push(case(format!("tail-{extra}.mha"), mha, error(promises)));
        let zlib_inside = metaimage("CompressedData = True\n", &zlib(&[little(&VALUES), tail.clone()].concat()));
        cases.push(case(format!("tail-{extra}-inside-zlib.mha"), zlib_inside, error(promises)));
        let zlib_after = metaimage("CompressedData = True\n", &[zlib(&little(&VALUES)), tail.clone()].concat());
        cases.push(case(format!("tail-{extra}-after-zlib.mha"), zlib_after, error(promises)));
        let gzip_after = [gzip(&nifti(|_| {})), tail.clone()].concat();
        cases.push(case(format!("tail-{extra}-after-gzip.nii.gz"), gzip_after, error("gzip")));
        let raw = [little(&VALUES), tail].concat();
        cases.push(case(format!("tail-{extra}_2x2x2_int16.raw"), raw, error("promises 16 bytes")));
    }
    cases
}

pub(super) fn value_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let floats = |values: &[f32]| values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>();
    let doubles = |values: &[f64]| values.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>();
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    for (name, values) in [
        ("nan", [nan; 8]),
        ("inf", [inf; 8]),
        ("-inf", [-inf; 8]),
        ("mixed", [nan, inf, -inf, nan, nan, inf, nan, -inf]),
    ] {
        let words = "every one of the 8 voxels is NaN or infinite";
        cases.push(case(format!("all-{name}_2x2x2_float32.raw"), floats(&values), error(words)));
        let as_f64: Vec<f64> = values.iter().map(|&v| v as f64).collect();
        cases.push(case(format!("all-{name}_2x2x2_float64.raw"), doubles(&as_f64), error(words)));
    }
    for constant in [0.0f32, 7.0, -1024.0] {
        cases.push(case(
            format!("constant-{constant}_2x2x2_float32.raw"),
            floats(&[constant; 8]),
            opens([constant as f64; 2], ONE_MM),
        ));
    }
    cases.push(case("constant_2x2x2_uint8.raw", vec![9; 8], opens([9.0; 2], ONE_MM)));
    cases.push(case(
        "some-nan_2x2x2_float32.raw",
        floats(&[nan, 1.0, 2.0, inf, 3.0, 4.0, 5.0, 6.0]),
        opens([1.0, 6.0], ONE_MM),
    ));
    for value in [1e39, -1e300, f64::MAX] {
        let words = "beyond the range of 32-bit floats";
        cases.push(case(
            format!("beyond-{value:e}_2x2x2_float64.raw"),
            doubles(&[0.0, 0.0, 0.0, value, 0.0, 0.0, 0.0, 0.0]),
            error(words),
        ));
    }
    // Data declared compressed that are raw: named as not compressed, not as corrupt gzip.
    let raw_data = little(&VALUES);
    for (name, bytes, declaration) in [
        ("raw-as-zlib.mha", metaimage("CompressedData = True\n", &raw_data), "'CompressedData = True'"),
        ("raw-as-one.mha", metaimage("CompressedData = 1\n", &raw_data), "'CompressedData = True'"),
        ("raw-as-gzip.nrrd", nrrd_over("", "gzip", &raw_data), "'encoding: gzip'"),
    ] {
        cases.push(case(name, bytes, error(format!("the data are not compressed as {declaration} declares"))));
    }
    cases
}
