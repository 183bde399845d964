//! Generated cases for header fields: spacings, fields given twice, byte-order and compression
//! flags, ASCII values.

use super::*;

pub(super) fn spacing_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let words = "voxel spacing";
    // Spacings no scan has, in every format's field and through `--spacing`.
    for value in [1e30, 1e-30, 1e5, 5e-5, 1e300, 2e-7, 0.0, -1.0, f64::INFINITY] {
        cases.push(case(
            format!("spacings-{value:e}.nrrd"),
            nrrd(&format!("spacings: 1 {value} 1\n"), "raw"),
            error(words),
        ));
        cases.push(case(
            format!("spacings-{value:e}.gz.nrrd"),
            nrrd(&format!("spacings: {value} 1 1\n"), "gzip"),
            error(words),
        ));
        let directions = format!("space dimension: 3\nspace directions: (1,0,0) (0,1,0) (0,0,{value})\n");
        // A direction's length is its spacing: a negative component only points it the other way.
        let expect = if value == -1.0 { opens(RANGE, ONE_MM) } else { error(words) };
        cases.push(case(format!("directions-{value:e}.nrrd"), nrrd(&directions, "raw"), expect));
        let mha = metaimage(&format!("ElementSpacing = 1 1 {value}\n"), &little(&VALUES));
        cases.push(case(format!("spacing-{value:e}.mha"), mha, error(words)));
        if value > 0.0 {
            // pixdim 0 means "not given" and a negative pixdim counts by its size (below); the
            // command line refuses 0 and -1 itself (a usage error).
            let bytes = nifti(|h| set_f32(h, 84, value as f32));
            cases.push(case(format!("pixdim-{value:e}.nii"), bytes.clone(), error(words)));
            cases.push(case(format!("pixdim-{value:e}.nii.gz"), gzip(&bytes), error(words)));
            if value.is_finite() {
                let name = format!("spacing-{value:e}_2x2x2_int16.raw");
                cases.push(raw_with_spacing(name, little(&VALUES), &format!("1,1,{value}"), error(words)));
            }
        }
    }
    // The bounds and a usual value open as given.
    for value in [1e-4, 1e4, 0.35] {
        let spacing = [1.0, value, 1.0];
        cases.push(case(
            format!("edge-{value:e}.nrrd"),
            nrrd(&format!("spacings: 1 {value} 1\n"), "raw"),
            opens(RANGE, spacing),
        ));
        let mha = metaimage(&format!("ElementSpacing = 1 {value} 1\n"), &little(&VALUES));
        cases.push(case(format!("edge-{value:e}.mha"), mha, opens(RANGE, spacing)));
        let name = format!("edge-{value:e}_2x2x2_int16.raw");
        cases.push(raw_with_spacing(name, little(&VALUES), &format!("1,{value},1"), opens(RANGE, spacing)));
        let bytes = nifti(|h| set_f32(h, 84, value as f32));
        cases.push(case(format!("edge-{value:e}.nii"), bytes, opens(RANGE, [1.0, value as f32 as f64, 1.0])));
    }
    // No spacing given (NRRD NaN, NIfTI pixdim 0): 1 mm, and a warning that says so.
    let half = [0.5, 0.5, 1.0];
    cases.push(case("nan.nrrd", nrrd("spacings: 0.5 0.5 NaN\n", "raw"), warns(RANGE, half, "no spacing for axis z")));
    cases.push(case(
        "nan.gz.nrrd",
        nrrd("spacings: 0.5 0.5 NaN\n", "gzip"),
        warns(RANGE, half, "no spacing for axis z"),
    ));
    let nan_direction = nrrd("space dimension: 3\nspace directions: (1,0,0) (0,NaN,0) (0,0,1)\n", "raw");
    cases.push(case("direction-nan.nrrd", nan_direction, error("voxel spacing NaN mm along y")));
    for axis in 0..3 {
        let mut spacing = [2.0; 3];
        spacing[axis] = 1.0;
        let bytes =
            nifti(|h| (0..3).for_each(|other| set_f32(h, 80 + 4 * other, if other == axis { 0.0 } else { 2.0 })));
        let words = ["pixdim[1] is 0", "pixdim[2] is 0", "pixdim[3] is 0"][axis];
        cases.push(case(format!("pixdim-zero-{axis}.nii"), bytes.clone(), warns(RANGE, spacing, words)));
        cases.push(case(format!("pixdim-zero-{axis}.nii.gz"), gzip(&bytes), warns(RANGE, spacing, words)));
    }
    for value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let bytes = nifti(|h| set_f32(h, 80, value));
        cases.push(case(format!("pixdim-{value:e}.nii"), bytes.clone(), error("voxel spacing")));
        cases.push(case(format!("pixdim-{value:e}.nii.gz"), gzip(&bytes), error("voxel spacing")));
    }
    cases.push(case("pixdim-negative.nii", nifti(|h| set_f32(h, 84, -0.5)), opens(RANGE, [1.0, 0.5, 1.0])));
    cases
}

pub(super) fn repeated_field_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let twice = "given twice with different values";
    for (field, repeated) in [
        ("sizes", "sizes: 2 2 1"),
        ("sizes", "sizes: 4 4 4"),
        ("type", "type: uchar"),
        ("type", "type: ushort"),
        ("endian", "endian: big"),
        ("encoding", "encoding: gzip"),
        ("dimension", "dimension: 2"),
        ("spacings", "spacings: 1 1 1\nspacings: 2 2 2"),
        ("byte skip", "byte skip: 0\nbyteskip: 2"),
    ] {
        let bytes = nrrd(&format!("{repeated}\n"), "raw");
        cases.push(case(
            format!("twice-{}.nrrd", repeated.replace([' ', ':', '\n'], "-")),
            bytes,
            error(format!("'{field}' is {twice}")),
        ));
    }
    for repeated in ["sizes: 2  2 2", "type: short", "Endian: little", "spacings: 1 1 1\nspacings: 1 1 1"] {
        let bytes = nrrd(&format!("{repeated}\n"), "raw");
        cases.push(case(format!("same-{}.nrrd", repeated.replace([' ', ':', '\n'], "-")), bytes, opens(RANGE, ONE_MM)));
    }
    for (field, repeated) in [
        ("DimSize", "DimSize = 2 2 1"),
        ("DimSize", "DimSize = 4 4 4"),
        ("ElementType", "ElementType = MET_UCHAR"),
        ("NDims", "NDims = 2"),
        ("ElementSpacing", "ElementSpacing = 1 1 1\nElementSpacing = 1 1 3"),
        ("BinaryDataByteOrderMSB", "BinaryDataByteOrderMSB = False\nBinaryDataByteOrderMSB = True"),
        ("CompressedData", "CompressedData = False\nCompressedData = True"),
        ("HeaderSize", "HeaderSize = 0\nHeaderSize = 4"),
    ] {
        let bytes = metaimage(&format!("{repeated}\n"), &little(&VALUES));
        cases.push(case(
            format!("twice-{}.mha", repeated.replace([' ', '=', '\n'], "-")),
            bytes,
            error(format!("'{field}' is {twice}")),
        ));
    }
    for repeated in ["dimsize = 2 2  2", "ElementType = MET_SHORT", "ElementSpacing = 1 1 1\nELEMENTSPACING = 1 1 1"] {
        let bytes = metaimage(&format!("{repeated}\n"), &little(&VALUES));
        cases.push(case(format!("same-{}.mha", repeated.replace([' ', '=', '\n'], "-")), bytes, opens(RANGE, ONE_MM)));
    }
    cases
}

pub(super) fn byte_order_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for field in ["BinaryDataByteOrderMSB", "ElementByteOrderMSB"] {
        for (value, msb) in [
            ("True", true),
            ("true", true),
            ("TRUE", true),
            ("1", true),
            ("False", false),
            ("false", false),
            ("0", false),
        ] {
            let data = if msb { big(&VALUES) } else { little(&VALUES) };
            let name = format!("{field}-{value}");
            cases.push(case(
                format!("{name}.mha"),
                metaimage(&format!("{field} = {value}\n"), &data),
                opens(RANGE, ONE_MM),
            ));
            let compressed = metaimage(&format!("{field} = {value}\nCompressedData = True\n"), &zlib(&data));
            cases.push(case(format!("{name}-zlib.mha"), compressed, opens(RANGE, ONE_MM)));
        }
        for value in ["yes", "2", "T", "big"] {
            let bytes = metaimage(&format!("{field} = {value}\n"), &big(&VALUES));
            cases.push(case(format!("{field}-{value}.mha"), bytes, error(format!("'{field}' is invalid: '{value}'"))));
        }
    }
    let conflict = metaimage("BinaryDataByteOrderMSB = True\nElementByteOrderMSB = 0\n", &big(&VALUES));
    cases.push(case("msb-conflict.mha", conflict, error("byte order cannot be told")));
    for value in ["1", "true", "TRUE"] {
        let bytes = metaimage(&format!("CompressedData = {value}\n"), &zlib(&little(&VALUES)));
        cases.push(case(format!("compressed-{value}.mha"), bytes, opens(RANGE, ONE_MM)));
    }
    // ITK's reader takes gzip as well as zlib.
    let gzip_data = metaimage("CompressedData = True\n", &gzip(&little(&VALUES)));
    cases.push(case("compressed-gzip.mha", gzip_data, opens(RANGE, ONE_MM)));
    cases
}

pub(super) fn ascii_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    let ascii = |nrrd_type: &str, values: &str| {
        format!("NRRD0004\ntype: {nrrd_type}\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\n0\n{values}\n")
            .into_bytes()
    };
    for (nrrd_type, value, problem) in [
        ("uint8", "300", "is outside the range of uint8"),
        ("uint8", "256", "is outside the range of uint8"),
        ("uint8", "-1", "is outside the range of uint8"),
        ("uint8", "2.5", "is not a whole number, as needed for uint8"),
        ("int8", "128", "is outside the range of int8"),
        ("int8", "-129", "is outside the range of int8"),
        ("short", "1e9", "is outside the range of int16"),
        ("short", "32768", "is outside the range of int16"),
        ("short", "0.5", "is not a whole number"),
        ("short", "nan", "is not a whole number"),
        ("ushort", "65536", "is outside the range of uint16"),
        ("int", "2147483648", "is outside the range of int32"),
        ("uint", "4294967296", "is outside the range of uint32"),
        ("uint", "-1", "is outside the range of uint32"),
        ("float", "1e39", "is outside the range of float32"),
        ("float", "-4e38", "is outside the range of float32"),
        ("double", "1e400", "is outside the range of float64"),
        ("short", "12x", "is not a number"),
    ] {
        let words = format!("the ASCII value '{value}' on line 8 {problem}");
        cases.push(case(format!("ascii-{nrrd_type}-{value}.nrrd"), ascii(nrrd_type, value), error(words)));
    }
    for (nrrd_type, value) in [
        ("uint8", 255.0),
        ("int8", -128.0),
        ("short", -32768.0),
        ("ushort", 65535.0),
        ("int", -2147483648.0),
        ("uint", 4294967295.0),
        ("float", 16777216.0),
        ("double", -0.125),
    ] {
        let range = if value < 0.0 { [value, 0.0] } else { [0.0, value] };
        cases.push(case(
            format!("ascii-{nrrd_type}-{value:e}-fits.nrrd"),
            ascii(nrrd_type, &format!("{value:e}")),
            opens(range, ONE_MM),
        ));
    }
    cases
}
