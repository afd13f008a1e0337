//! The operating system transports (feature `os`, on by default): what sits between a device
//! codec of this crate and the machine.
//!
//! | module        | what                                                                   |
//! |---------------|------------------------------------------------------------------------|
//! | [`firewire`]  | the PHANTOM Omni over Linux firewire-cdev (`/dev/fw*`): a [`FirewireTransport`](crate::omni::FirewireTransport) and discovery by configuration ROM |
//! | [`hdapi`]     | the Touch through the vendor HD library, loaded at run time: an [`HdLibrary`](crate::touch::HdLibrary) |
//! | [`clock`]     | the monotonic clock the transports measure their deadlines with        |
//!
//! These are the only modules of the crate with `unsafe`: each file that needs it allows it at
//! its top, and each block is one system call, one library call or one copy in a mapped
//! buffer, with its `// SAFETY:` reason.

pub mod clock;
pub mod firewire;
pub mod hdapi;
