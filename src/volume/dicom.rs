//! placeholder: filled in by the format work of issue 2.
