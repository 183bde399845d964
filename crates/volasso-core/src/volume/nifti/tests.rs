use super::*;

/// A minimal little-endian single-file header for `dims` of `datatype`.
pub(crate) fn header_bytes(
    dims: [i16; 3],
    datatype: i16,
    bitpix: i16,
    pixdim: [f32; 3],
    slope: f32,
    intercept: f32,
) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    h[40..42].copy_from_slice(&3i16.to_le_bytes());
    for (i, d) in dims.iter().enumerate() {
        h[42 + 2 * i..44 + 2 * i].copy_from_slice(&d.to_le_bytes());
    }
    h[70..72].copy_from_slice(&datatype.to_le_bytes());
    h[72..74].copy_from_slice(&bitpix.to_le_bytes());
    for (i, p) in pixdim.iter().enumerate() {
        h[80 + 4 * i..84 + 4 * i].copy_from_slice(&p.to_le_bytes());
    }
    h[108..112].copy_from_slice(&352f32.to_le_bytes());
    h[112..116].copy_from_slice(&slope.to_le_bytes());
    h[116..120].copy_from_slice(&intercept.to_le_bytes());
    h[344..348].copy_from_slice(b"n+1\0");
    h
}

#[test]
fn parses_a_little_endian_header_with_scaling() {
    let bytes = header_bytes([4, 3, 2], 4, 16, [0.5, 0.75, 2.0], 2.0, -1024.0);
    let header = parse_header(&bytes, Path::new("t.nii")).unwrap();
    assert_eq!(header.dims, [4, 3, 2]);
    assert_eq!(header.voxel_type, VoxelType::I16);
    assert_eq!(header.spacing_mm, [0.5, 0.75, 2.0]);
    assert_eq!(header.scale, ValueScale { slope: 2.0, intercept: -1024.0 });
    assert_eq!(header.data_offset, 352);
}

#[test]
fn slope_zero_means_no_scaling() {
    let bytes = header_bytes([4, 3, 2], 2, 8, [1.0; 3], 0.0, 5.0);
    assert_eq!(parse_header(&bytes, Path::new("t.nii")).unwrap().scale, ValueScale::IDENTITY);
}

#[test]
fn refuses_bad_headers() {
    let good = header_bytes([4, 3, 2], 4, 16, [1.0; 3], 1.0, 0.0);
    type Corruption = Box<dyn Fn(&mut Vec<u8>)>;
    let cases: Vec<(&str, Corruption)> = vec![
        ("short", Box::new(|h| h.truncate(100))),
        ("sizeof_hdr", Box::new(|h| h[0] = 7)),
        ("magic", Box::new(|h| h[344] = b'x')),
        ("datatype", Box::new(|h| h[70..72].copy_from_slice(&1024i16.to_le_bytes()))),
        ("bitpix", Box::new(|h| h[72..74].copy_from_slice(&8i16.to_le_bytes()))),
        ("negative dim", Box::new(|h| h[42..44].copy_from_slice(&(-4i16).to_le_bytes()))),
        ("rank", Box::new(|h| h[40..42].copy_from_slice(&9i16.to_le_bytes()))),
        ("vox_offset", Box::new(|h| h[108..112].copy_from_slice(&f32::NAN.to_le_bytes()))),
    ];
    for (name, corrupt) in cases {
        let mut bytes = good.clone();
        corrupt(&mut bytes);
        assert!(parse_header(&bytes, Path::new("t.nii")).is_err(), "{name} accepted");
    }
}

fn with_dim(mut bytes: Vec<u8>, index: usize, size: i16) -> Vec<u8> {
    let rank = i16::from_le_bytes([bytes[40], bytes[41]]).max(index as i16);
    bytes[40..42].copy_from_slice(&rank.to_le_bytes());
    bytes[40 + 2 * index..42 + 2 * index].copy_from_slice(&size.to_le_bytes());
    bytes
}

#[test]
fn series_vectors_and_colour_are_refused_like_nrrd_and_metaimage() {
    let good = header_bytes([4, 3, 2], 4, 16, [1.0; 3], 1.0, 0.0);
    for (index, size, expected) in [
        (4, 2, "dim[4] = 2"),
        (4, 300, "dim[4] = 300"),
        (5, 3, "dim[5] = 3"),
        (6, 2, "dim[6] = 2"),
        (7, 4, "dim[7] = 4"),
    ] {
        let error = parse_header(&with_dim(good.clone(), index, size), Path::new("t.nii")).unwrap_err();
        assert!(
            matches!(&error, VolumeError::Unsupported { value, .. } if value == expected),
            "dim[{index}] = {size}: {error}"
        );
    }
    // One volume of one component, said explicitly, is a 3-D scalar volume.
    let one = with_dim(with_dim(good.clone(), 4, 1), 5, 1);
    assert_eq!(parse_header(&one, Path::new("t.nii")).unwrap().dims, [4, 3, 2]);
    for (datatype, bitpix) in [(128, 24), (2304, 32)] {
        let bytes = header_bytes([4, 3, 2], datatype, bitpix, [1.0; 3], 1.0, 0.0);
        let error = parse_header(&bytes, Path::new("t.nii")).unwrap_err();
        assert!(error.to_string().contains("colour"), "{datatype}: {error}");
    }
}

#[test]
fn pixdim_zero_warns_and_unusable_pixdims_are_refused() {
    let header = parse_header(&header_bytes([4, 3, 2], 4, 16, [0.0, 0.5, 2.0], 1.0, 0.0), Path::new("t")).unwrap();
    assert_eq!(header.spacing_mm, [1.0, 0.5, 2.0]);
    assert_eq!(header.warnings.len(), 1);
    assert!(
        header.warnings[0].contains("pixdim[1] is 0") && header.warnings[0].contains("0.5 mm"),
        "{:?}",
        header.warnings
    );
    // Along a single slice the spacing changes nothing: no warning.
    let flat = parse_header(&header_bytes([4, 3, 1], 4, 16, [0.5, 0.5, 0.0], 1.0, 0.0), Path::new("t")).unwrap();
    assert_eq!((flat.spacing_mm, flat.warnings.len()), ([0.5, 0.5, 1.0], 0));
    let negative = parse_header(&header_bytes([4, 3, 2], 4, 16, [-0.5, 0.5, 2.0], 1.0, 0.0), Path::new("t")).unwrap();
    assert_eq!(negative.spacing_mm, [0.5, 0.5, 2.0]);
    for value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, 1e-30, 2e4, 5e-5] {
        for axis in 0..3 {
            let mut pixdim = [1.0f32; 3];
            pixdim[axis] = value;
            let error = parse_header(&header_bytes([4, 3, 2], 4, 16, pixdim, 1.0, 0.0), Path::new("t")).unwrap_err();
            assert!(
                matches!(error, VolumeError::BadSpacing { axis: a, .. } if a == axis),
                "{value} on {axis}: {error}"
            );
        }
    }
}

#[test]
fn scaling_is_applied_ignored_as_the_standard_says_or_refused() {
    let scale = |slope: f32, intercept: f32| {
        parse_header(&header_bytes([4, 3, 2], 4, 16, [1.0; 3], slope, intercept), Path::new("t"))
            .map(|h| (h.scale, h.warnings.len()))
    };
    assert_eq!(scale(2.0, -1024.0).unwrap(), (ValueScale { slope: 2.0, intercept: -1024.0 }, 0));
    assert_eq!(scale(0.0, 0.0).unwrap(), (ValueScale::IDENTITY, 0));
    assert_eq!(scale(f32::NAN, f32::NAN).unwrap(), (ValueScale::IDENTITY, 0), "nibabel's unscaled");
    assert_eq!(scale(f32::NAN, 0.0).unwrap(), (ValueScale::IDENTITY, 0));
    assert_eq!(scale(f32::NAN, -1024.0).unwrap(), (ValueScale::IDENTITY, 1), "an unused intercept is said");
    assert_eq!(scale(0.0, 5.0).unwrap(), (ValueScale::IDENTITY, 1));
    for (slope, intercept, field) in [
        (f32::INFINITY, 0.0, "scl_slope"),
        (f32::NEG_INFINITY, 1.0, "scl_slope"),
        (2.0, f32::NAN, "scl_inter"),
        (1.0, f32::INFINITY, "scl_inter"),
        (-3.0, f32::NEG_INFINITY, "scl_inter"),
    ] {
        let error = scale(slope, intercept).unwrap_err();
        assert!(matches!(&error, VolumeError::Header { field: f, .. } if f == field), "{slope} {intercept}: {error}");
    }
}

proptest::proptest! {
    /// Any header bytes parse or fail cleanly; an accepted header never promises an
    /// overflowing voxel count or a data offset inside the header of a single file.
    #[test]
    fn parse_never_panics(mut bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 348..400), little in proptest::prelude::any::<bool>()) {
        if little {
            bytes[0..4].copy_from_slice(&348i32.to_le_bytes());
            bytes[344..348].copy_from_slice(b"n+1\0");
        }
        if let Ok(header) = parse_header(&bytes, Path::new("t.nii")) {
            proptest::prop_assert!(checked_voxel_count(header.dims, header.voxel_type, Path::new("t")).is_ok());
            proptest::prop_assert!(header.separate_image_file || header.data_offset >= HEADER_BYTES as u64);
        }
    }
}
