//! Devices: device files, the Falcon's and the Omni's start-up, the Touch loader and device
//! faults at the servo tick, against mock transports; one test binary, a module per file.

mod device_config;
mod falcon_startup;
mod faults_device;
mod hdapi;
mod omni_startup;
mod sim_models;
