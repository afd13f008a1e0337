//! Soft bodies and deforming worlds: the soft step against elasticity, spread over ticks and
//! linked to the servo, regions, the premolar, the command line; one test binary, a module per
//! file.

mod deform_spread;
mod deform_world;
mod soft_block;
mod soft_body;
mod soft_cli;
mod soft_golden;
mod soft_link;
mod soft_regions;
mod soft_spread;
mod soft_tooth;
