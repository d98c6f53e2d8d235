//! C ABI for DynaSlice (see docs/c-api.md).
