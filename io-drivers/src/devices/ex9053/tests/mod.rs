//! Tests across the EX-9053D files: every example of the manual against the simulator
//! (string- or byte-exact, with and without checksum), and the driver on the virtual line.

mod driver_line;
mod manual_dcon;
mod manual_modbus;
mod uart;
