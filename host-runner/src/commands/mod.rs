//! One file per command.

pub mod info;
pub mod replay;
pub mod timing;
