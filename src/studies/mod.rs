//! The thesis's protocols on the shipped data sets: the identification case studies A-D over
//! many seeds ([`reproduce`]) and Case D end to end with the compensator ([`case_d`]). The
//! files, the noise and the thesis's published figures they share are in [`thesis`].

pub mod case_d;
pub mod planning;
pub mod reproduce;
pub mod thesis;
