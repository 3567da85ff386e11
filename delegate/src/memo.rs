//! Values an assembly derives from a converted prim's geometry for some key (the core meshes
//! of a mesh for a shutter, the points of a points prim folded over it), kept with the
//! geometry so that the assemblies that follow (another prim edited) share them rather than
//! make them again.

use std::sync::Mutex;

/// The value last made, and the key it was made for. Not part of the geometry's value:
/// clones start empty and equality ignores it.
pub struct Memo<K, V>(Mutex<Option<(K, V)>>);

impl<K: PartialEq, V: Clone> Memo<K, V> {
    /// The value for `key`: the one made last if it was made for `key`, else `make()`'s,
    /// which is kept in its place.
    pub fn get_or_make(&self, key: K, make: impl FnOnce() -> V) -> V {
        let mut last = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, v)) = last.as_ref().filter(|l| l.0 == key) {
            return v.clone();
        }
        let v = make();
        *last = Some((key, v.clone()));
        v
    }
}

impl<K, V> Default for Memo<K, V> {
    fn default() -> Self {
        Memo(Mutex::new(None))
    }
}

impl<K, V> Clone for Memo<K, V> {
    fn clone(&self) -> Self {
        Memo::default()
    }
}

impl<K, V> PartialEq for Memo<K, V> {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<K, V> std::fmt::Debug for Memo<K, V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Memo")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_is_made_once_per_key_in_a_row() {
        let m: Memo<u32, std::sync::Arc<u32>> = Memo::default();
        let mut made = 0;
        let mut get = |k: u32| {
            m.get_or_make(k, || {
                made += 1;
                std::sync::Arc::new(k * 10)
            })
        };
        let a = get(1);
        assert!(std::sync::Arc::ptr_eq(&a, &get(1)));
        assert_eq!(*get(2), 20);
        assert_eq!(*get(1), 10);
        drop(get);
        assert_eq!(made, 3, "only the last key is kept");
        assert_eq!(m.clone(), m);
    }
}
