//! Contact: the burr's contact search, the spatial hash and the zone gathers, and the pen's
//! contact pass (collision lists, depth, the servo's half, two threads, the real-time pipeline),
//! each against an oracle of its own; one test binary, a module per file.

mod bounds_contact;
mod contact_depth;
mod contact_hash;
mod contact_search;
mod contact_search_resume;
mod contact_servo;
mod handoffs;
mod pen_pair;
mod pen_pipeline;
mod pen_reference;
mod shaft_bound;
mod shaft_seed;
mod shaft_zones;
mod zone_gather;
mod zone_memo;
