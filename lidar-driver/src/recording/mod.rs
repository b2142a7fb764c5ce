//! Recording readers (in progress).
