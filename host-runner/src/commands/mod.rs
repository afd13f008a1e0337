//! One file per command.

pub mod demo;
pub mod devices;
pub mod export;
pub mod info;
pub mod pipeline;
pub mod replay;
pub mod run;
pub mod timing;
