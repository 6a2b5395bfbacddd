//! Bad input gets a typed error naming the polygon and the problem.
