//! `lattice-gas`: see its issue; filled in by its own crate work.
