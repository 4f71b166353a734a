//! Allocation-free copies of solver state, for rolling a warm-started solver back to
//! its state after the last converged solve (`TendonWorkspace`'s rollback).
//!
//! [`WarmCopy::warm_copy_from`] makes `self` equal to `src` in every value a later
//! solve reads, reusing `self`'s buffers: a `Vec` of the same length is copied
//! element by element (no allocation), one of another length is cloned (allocates:
//! only when the shapes differ, i.e. the first copy or after a re-mesh). Why not
//! `Clone::clone_from`: derived `Clone` implementations allocate a fresh copy of
//! every buffer in `clone_from`; the control loop's rows must not allocate.
//!
//! Structs implement it with [`warm_fields!`], which destructures the source
//! exhaustively: a field added later is a compile error until it is listed as
//! copied or as configuration (not part of the warm state).

use nalgebra::{SMatrix, Scalar};

/// Copy the warm state of `src` into `self` without allocating when the buffer
/// shapes agree (module docs).
pub(crate) trait WarmCopy {
    /// Make `self`'s warm state equal to `src`'s.
    fn warm_copy_from(&mut self, src: &Self);
}

/// `WarmCopy` by assignment, for `Copy` types.
macro_rules! warm_by_copy {
    ($($t:ty),* $(,)?) => {
        $(impl $crate::math::warm::WarmCopy for $t {
            #[inline]
            fn warm_copy_from(&mut self, src: &Self) {
                *self = *src;
            }
        })*
    };
}
pub(crate) use warm_by_copy;

/// The body of a struct's `warm_copy_from`: `copy` fields are copied, `keep`
/// fields (configuration, fixed while solving) are left as they are. Every field
/// must be named in one of the lists (the source is destructured exhaustively).
macro_rules! warm_fields {
    ($self:ident, $src:ident, copy: [$($f:ident),* $(,)?], keep: [$($k:ident),* $(,)?]) => {{
        let Self { $($f,)* $($k: _,)* } = $src;
        $( $crate::math::warm::WarmCopy::warm_copy_from(&mut $self.$f, $f); )*
    }};
}
pub(crate) use warm_fields;

warm_by_copy!(f64, f32, bool, usize, u64, u32, i64, i32);

impl WarmCopy for String {
    fn warm_copy_from(&mut self, src: &Self) {
        self.clone_from(src);
    }
}

impl<T: WarmCopy + Clone> WarmCopy for Vec<T> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        if self.len() == src.len() {
            for (a, b) in self.iter_mut().zip(src) {
                a.warm_copy_from(b);
            }
        } else {
            // another shape: the only allocating case
            *self = src.clone();
        }
    }
}

impl<T: WarmCopy + Clone> WarmCopy for Option<T> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        match (self.as_mut(), src) {
            (Some(a), Some(b)) => a.warm_copy_from(b),
            (_, None) => *self = None,
            (None, Some(b)) => *self = Some(b.clone()),
        }
    }
}

impl<T: WarmCopy + ?Sized> WarmCopy for Box<T> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        (**self).warm_copy_from(src);
    }
}

impl<T: WarmCopy, const N: usize> WarmCopy for [T; N] {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        for (a, b) in self.iter_mut().zip(src) {
            a.warm_copy_from(b);
        }
    }
}

impl<A: WarmCopy, B: WarmCopy> WarmCopy for (A, B) {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        self.0.warm_copy_from(&src.0);
        self.1.warm_copy_from(&src.1);
    }
}

impl<T: Scalar + Copy, const R: usize, const C: usize> WarmCopy for SMatrix<T, R, C> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        *self = *src;
    }
}

impl WarmCopy for std::ops::Range<usize> {
    #[inline]
    fn warm_copy_from(&mut self, src: &Self) {
        self.clone_from(src);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct S {
        a: Vec<f64>,
        b: Option<Vec<Vec<f64>>>,
        n: usize,
        cfg: String,
    }
    impl WarmCopy for S {
        fn warm_copy_from(&mut self, src: &Self) {
            warm_fields!(self, src, copy: [a, b, n], keep: [cfg]);
        }
    }

    /// Same shapes: equal values, the buffers kept; `keep` fields untouched.
    #[test]
    fn copies_values_into_the_same_buffers() {
        let mut d = S {
            a: vec![0.0; 3],
            b: Some(vec![vec![0.0; 2]]),
            n: 0,
            cfg: "mine".into(),
        };
        let s = S {
            a: vec![1.0, 2.0, 3.0],
            b: Some(vec![vec![4.0, 5.0]]),
            n: 7,
            cfg: "theirs".into(),
        };
        let ptr = d.a.as_ptr();
        d.warm_copy_from(&s);
        assert_eq!(d.a, s.a);
        assert_eq!(d.b, s.b);
        assert_eq!(d.n, 7);
        assert_eq!(d.cfg, "mine");
        assert_eq!(d.a.as_ptr(), ptr);
    }
}
