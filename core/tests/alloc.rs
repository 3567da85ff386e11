//! What the renderer's per-instance records take from the heap, counted by a global allocator
//! that counts this thread's allocations.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn allocations<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let before = ALLOCATIONS.with(Cell::get);
    let out = f();
    (out, ALLOCATIONS.with(Cell::get) - before)
}

/// A transform with one sample (every instance that does not move: a scene of a million
/// instances holds a million) is held inline, matrix and inverse, with nothing on the heap;
/// one that moves keeps its samples there.
#[test]
fn a_still_transform_takes_nothing_from_the_heap() {
    use glam::{Mat4, Quat, Vec3};
    use tide_core::accel::motion::MotionTransform;
    let m = Mat4::from_scale_rotation_translation(Vec3::new(1.0, 2.0, 0.5), Quat::from_rotation_y(0.3), Vec3::new(4.0, -1.0, 2.0));
    let (still, n) = allocations(|| MotionTransform::new(&[m], &[0.0]));
    assert_eq!(n, 0, "allocations for a transform of one sample");
    assert!(still.is_static() && still.at(0.7) == m);
    let (o, d) = still.ray_to_local(Vec3::new(4.0, -1.0, 2.0), Vec3::X, 0.0);
    assert!(o.length() < 1e-5 && (m.transform_vector3(d) - Vec3::X).length() < 1e-5);
    assert!(std::mem::size_of::<MotionTransform>() <= 2 * std::mem::size_of::<Mat4>() + 16);
    let (moving, n) = allocations(|| MotionTransform::new(&[m, Mat4::IDENTITY], &[0.0, 1.0]));
    assert!(n > 0 && !moving.is_static());
    assert_eq!((moving.at(0.0), moving.at(1.0)), (m, Mat4::IDENTITY));
}
