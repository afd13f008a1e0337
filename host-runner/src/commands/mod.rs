//! One file per command.

pub mod info;
pub mod timing;
