use super::*;
use proptest::prelude::*;

const HEADER: &str = "NRRD0004\n# a comment\ntype: short\ndimension: 3\nsizes: 4 3 2\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,2)\nendian: big\nencoding: raw\nkey:=value\n\n";

#[test]
fn parses_fields_and_finds_the_data() {
    let header = parse_header(HEADER.as_bytes(), Path::new("t.nrrd")).unwrap();
    assert_eq!(header.voxel_type, VoxelType::I16);
    assert_eq!(header.dims, [4, 3, 2]);
    assert_eq!(header.spacing_mm, [0.5, 0.5, 2.0]);
    assert_eq!(header.byte_order, ByteOrder::Big);
    assert_eq!(header.encoding, NrrdEncoding::Raw);
    assert_eq!(header.header_length, Some(HEADER.len()));
}

#[test]
fn every_type_spelling_is_known() {
    for (names, expected) in [
        (&["signed char", "int8", "int8_t"][..], VoxelType::I8),
        (&["uchar", "unsigned char", "uint8", "uint8_t"][..], VoxelType::U8),
        (&["short", "short int", "signed short", "signed short int", "int16", "int16_t"][..], VoxelType::I16),
        (&["ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"][..], VoxelType::U16),
        (&["int", "signed int", "int32", "int32_t"][..], VoxelType::I32),
        (&["uint", "unsigned int", "uint32", "uint32_t"][..], VoxelType::U32),
        (&["float"][..], VoxelType::F32),
        (&["double"][..], VoxelType::F64),
    ] {
        for name in names {
            assert_eq!(type_from_name(name), Some(expected), "{name}");
        }
    }
    assert_eq!(type_from_name("int64"), None);
    assert_eq!(type_from_name("block"), None);
}

#[test]
fn spacings_and_none_directions() {
    let text = HEADER.replace("space directions: (0.5,0,0) (0,0.5,0) (0,0,2)", "spacings: 0.7 0.8 NaN");
    let header = parse_header(text.as_bytes(), Path::new("t")).unwrap();
    assert_eq!(header.spacing_mm, [0.7, 0.8, 1.0]);
    assert_eq!(header.warnings.len(), 1, "a spatial axis without spacing beside known ones is said");
    assert!(header.warnings[0].contains("axis z") && header.warnings[0].contains("0.7 mm"), "{:?}", header.warnings);
    let vector = HEADER
        .replace("dimension: 3\nsizes: 4 3 2", "dimension: 4\nsizes: 1 4 3 2")
        .replace("space directions: (0.5,0,0)", "space directions: none (0.5, 0, 0)");
    let header = parse_header(vector.as_bytes(), Path::new("t")).unwrap();
    assert_eq!((header.dims, header.spacing_mm), ([4, 3, 2], [0.5, 0.5, 2.0]));
}

#[test]
fn refuses_malformed_headers() {
    for (name, text) in [
        ("magic", HEADER.replace("NRRD0004", "NRRD0009")),
        ("no type", HEADER.replace("type: short\n", "")),
        ("unknown type", HEADER.replace("type: short", "type: int64")),
        ("dimension", HEADER.replace("dimension: 3", "dimension: three")),
        ("sizes count", HEADER.replace("sizes: 4 3 2", "sizes: 4 3")),
        ("zero size", HEADER.replace("sizes: 4 3 2", "sizes: 4 0 2")),
        ("overflow", HEADER.replace("sizes: 4 3 2", "sizes: 18446744073709551615 3 2")),
        ("huge", HEADER.replace("sizes: 4 3 2", "sizes: 4294967296 4294967296 4")),
        ("5-D", HEADER.replace("dimension: 3\nsizes: 4 3 2", "dimension: 5\nsizes: 2 4 3 2 2")),
        ("encoding", HEADER.replace("encoding: raw", "encoding: bzip2")),
        ("no endian", HEADER.replace("endian: big\n", "")),
        ("endian", HEADER.replace("endian: big", "endian: middle")),
        ("direction", HEADER.replace("(0,0,2)", "(0,0,x)")),
        ("zero spacing", HEADER.replace("(0,0,2)", "(0,0,0)")),
        ("list data file", HEADER.replace("encoding: raw", "encoding: raw\ndata file: LIST")),
        ("byte skip", HEADER.replace("encoding: raw", "encoding: raw\nbyte skip: -7")),
        ("gzip byte skip -1", HEADER.replace("encoding: raw", "encoding: gzip\nbyte skip: -1")),
        ("not a field", HEADER.replace("# a comment", "no colon here")),
    ] {
        assert!(parse_header(text.as_bytes(), Path::new("t")).is_err(), "{name} accepted");
    }
}

proptest! {
    /// Whatever bytes follow the magic, parsing returns (never panics), and an accepted header
    /// promises a voxel count that does not overflow.
    #[test]
    fn parse_never_panics(tail in proptest::collection::vec(any::<u8>(), 0..400)) {
        let mut bytes = b"NRRD0004\n".to_vec();
        bytes.extend(tail);
        if let Ok(header) = parse_header(&bytes, Path::new("t")) {
            prop_assert!(checked_voxel_count(header.dims, header.voxel_type, Path::new("t")).is_ok());
        }
    }

    /// Headers built from valid fields in any order parse to the same geometry.
    #[test]
    fn field_order_does_not_matter(
        dims in [1usize..50, 1usize..50, 1usize..50],
        spacing in [0.01f64..10.0, 0.01f64..10.0, 0.01f64..10.0],
        type_index in 0usize..8,
        rotation in 0usize..6,
    ) {
        let voxel_type = VoxelType::ALL[type_index];
        let mut fields = [
            format!("type: {}", type_name(voxel_type)),
            "dimension: 3".to_string(),
            format!("sizes: {} {} {}", dims[0], dims[1], dims[2]),
            format!("spacings: {} {} {}", spacing[0], spacing[1], spacing[2]),
            "endian: little".to_string(),
            "encoding: raw".to_string(),
        ];
        fields.rotate_left(rotation);
        let text = format!("NRRD0005\n{}\n\n", fields.join("\n"));
        let header = parse_header(text.as_bytes(), Path::new("t")).unwrap();
        prop_assert_eq!(header.dims, dims);
        prop_assert_eq!(header.voxel_type, voxel_type);
        prop_assert_eq!(header.spacing_mm, spacing);
    }

    /// What the writer writes, the reader reads back bit for bit; random float bits that hold
    /// no finite value, or one beyond `f32`'s range, are refused by name instead.
    #[test]
    fn write_then_read_round_trips(dims in [1usize..9, 1usize..9, 1usize..9], type_index in 0usize..8, seed in any::<u64>()) {
        let voxel_type = VoxelType::ALL[type_index];
        let length = dims.iter().product::<usize>() * voxel_type.size_bytes();
        let mut state = seed;
        let bytes: Vec<u8> = (0..length).map(|_| { state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); (state >> 56) as u8 }).collect();
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("v.nrrd");
        write(&path, dims, [0.5, 1.0, 2.5], voxel_type, ByteOrder::Little, &bytes, "test").unwrap();
        let values: Vec<f64> = match voxel_type {
            VoxelType::F32 => bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap()) as f64).collect(),
            VoxelType::F64 => bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect(),
            _ => vec![0.0],
        };
        if values.iter().all(|v| !v.is_finite()) {
            let refused = matches!(read(&path), Err(VolumeError::NoFiniteValue { .. }));
            prop_assert!(refused, "no finite value");
            return Ok(());
        }
        if values.iter().any(|v| v.is_finite() && v.abs() > f32::MAX as f64) {
            let refused = matches!(read(&path), Err(VolumeError::ValueOverflow { scaled: false, .. }));
            prop_assert!(refused, "beyond f32");
            return Ok(());
        }
        let read = read(&path).unwrap();
        prop_assert_eq!(read.volume.dims, dims);
        prop_assert_eq!(read.volume.spacing_mm, [0.5, 1.0, 2.5]);
        prop_assert_eq!(read.volume.raw_bytes(), &bytes[..]);
        prop_assert!(read.volume.is_memory_mapped());
    }
}

#[test]
fn a_field_given_twice_is_refused_unless_it_repeats_the_same_value() {
    for (name, extra) in [
        ("sizes", "sizes: 4 3 4\n"),
        ("type", "type: uchar\n"),
        ("endian", "endian: little\n"),
        ("encoding", "encoding: gzip\n"),
        ("dimension", "dimension: 2\n"),
        ("space directions", "space directions: (1,0,0) (0,1,0) (0,0,1)\n"),
        ("byte skip", "byte skip: 1\nbyteskip: 2\n"),
        ("data file", "data file: a.raw\ndatafile: b.raw\n"),
    ] {
        let text = HEADER.replace("key:=value\n", extra);
        let error = parse_header(text.as_bytes(), Path::new("t")).unwrap_err();
        assert!(
            matches!(&error, VolumeError::RepeatedField { field, .. } if field.replace(' ', "") == name.replace(' ', "")),
            "{name}: {error}"
        );
    }
    let same = HEADER.replace("key:=value\n", "sizes: 4  3 2\nType: short\n");
    let header = parse_header(same.as_bytes(), Path::new("t")).unwrap();
    assert_eq!((header.dims, header.voxel_type), ([4, 3, 2], VoxelType::I16));
}

#[test]
fn spacings_outside_what_any_scan_has_are_refused() {
    for spacing in ["1e30", "1e-30", "0", "-1", "inf", "1e5", "0.00001"] {
        // A direction's length is its spacing (a negative component only points it the other way).
        if spacing != "-1" {
            let text = HEADER.replace("(0,0,2)", &format!("(0,0,{spacing})"));
            let error = parse_header(text.as_bytes(), Path::new("t")).unwrap_err();
            assert!(matches!(error, VolumeError::BadSpacing { axis: 2, .. }), "{spacing}: {error}");
        }
        let text = HEADER.replace("space directions: (0.5,0,0) (0,0.5,0) (0,0,2)", &format!("spacings: {spacing} 1 1"));
        let error = parse_header(text.as_bytes(), Path::new("t")).unwrap_err();
        assert!(matches!(error, VolumeError::BadSpacing { axis: 0, .. }), "{spacing}: {error}");
    }
    for spacing in ["0.0001", "10000", "0.3"] {
        let text = HEADER.replace("(0,0,2)", &format!("(0,0,{spacing})"));
        assert!(parse_header(text.as_bytes(), Path::new("t")).is_ok(), "{spacing}");
    }
}

#[test]
fn ascii_values_are_stored_exactly_or_refused() {
    use super::ascii::ascii_value;
    use crate::volume::error::AsciiProblem::{NotANumber, NotWhole, OutOfRange};
    for (text, voxel_type, expected) in [
        ("255", VoxelType::U8, Ok(255.0)),
        ("1e2", VoxelType::U8, Ok(100.0)),
        ("-0", VoxelType::U8, Ok(0.0)),
        ("256", VoxelType::U8, Err(OutOfRange)),
        ("300", VoxelType::U8, Err(OutOfRange)),
        ("-1", VoxelType::U8, Err(OutOfRange)),
        ("-129", VoxelType::I8, Err(OutOfRange)),
        ("-32768", VoxelType::I16, Ok(-32768.0)),
        ("1e9", VoxelType::I16, Err(OutOfRange)),
        ("65536", VoxelType::U16, Err(OutOfRange)),
        ("4294967295", VoxelType::U32, Ok(4294967295.0)),
        ("4294967296", VoxelType::U32, Err(OutOfRange)),
        ("2147483648", VoxelType::I32, Err(OutOfRange)),
        ("4.5", VoxelType::I16, Err(NotWhole)),
        ("nan", VoxelType::I32, Err(NotWhole)),
        ("inf", VoxelType::U8, Err(NotWhole)),
        ("12abc", VoxelType::U8, Err(NotANumber)),
        ("1e39", VoxelType::F32, Err(OutOfRange)),
        ("-1e39", VoxelType::F32, Err(OutOfRange)),
        ("3e38", VoxelType::F32, Ok(3e38)),
        ("1e400", VoxelType::F64, Err(OutOfRange)),
        ("1e300", VoxelType::F64, Ok(1e300)),
        ("0.25", VoxelType::F32, Ok(0.25)),
    ] {
        assert_eq!(ascii_value(text, voxel_type), expected, "{text} as {voxel_type:?}");
    }
    assert!(ascii_value("nan", VoxelType::F32).unwrap().is_nan());
    assert_eq!(ascii_value("-inf", VoxelType::F64), Ok(f64::NEG_INFINITY));
}
