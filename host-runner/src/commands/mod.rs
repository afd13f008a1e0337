//! One file per command.

pub mod info;
