//! Mesh file readers. (Being written: see issue 2.)
