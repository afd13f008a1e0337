//! tetradrill-device: the haptic device layer (see `../shared/DESIGN.md` section 3).
#![forbid(unsafe_code)]
