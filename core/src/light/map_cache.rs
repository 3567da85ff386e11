//! Light maps kept from one world build to the next. A dome's sampling tables (texels × tint,
//! a 2D distribution over the whole image) cost about a tenth of a second per million texels,
//! a rect light's tinted texels less; an interactive session rebuilds the world at every
//! edit, so a light whose image (the same shared pixels), tint and colour space are unchanged
//! takes its map from here instead. After each build the cache holds exactly the maps that
//! build used.

use super::{DomeMap, RectMap};
use crate::scene::{ColorSpace, TextureDesc};
use std::sync::{Arc, Mutex};

/// What a light map is made from, besides its pixels.
#[derive(Clone, Copy, PartialEq)]
struct Key {
    dome: bool,
    width: u32,
    height: u32,
    channels: u32,
    tint: [u32; 3],
    cs: ColorSpace,
}

struct Entry {
    /// Held so that the address the entry is recognised by cannot be reused by other pixels.
    pixels: crate::texture::Texels,
    key: Key,
    map: Map,
}

#[derive(Clone)]
enum Map {
    Dome(Arc<DomeMap>),
    Rect(Arc<RectMap>),
}

impl Entry {
    fn is(&self, tex: &TextureDesc, key: Key) -> bool {
        self.pixels.same(&tex.pixels) && self.key == key
    }
}

/// Shared between builds (cloning shares it).
#[derive(Clone, Default)]
pub struct MapCache {
    entries: Arc<Mutex<Vec<Entry>>>,
}

impl MapCache {
    /// Starts a build: the last build's maps become candidates.
    pub(crate) fn begin(&self) -> MapSession {
        MapSession { old: std::mem::take(&mut *self.entries.lock().unwrap_or_else(|e| e.into_inner())), kept: Vec::new() }
    }

    /// Ends a build: the cache keeps the maps it used.
    pub(crate) fn end(&self, s: MapSession) {
        *self.entries.lock().unwrap_or_else(|e| e.into_inner()) = s.kept;
    }

    /// Maps held.
    pub fn len(&self) -> usize {
        self.entries.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The maps of one build.
pub(crate) struct MapSession {
    old: Vec<Entry>,
    kept: Vec<Entry>,
}

impl MapSession {
    /// The map of `tex` tinted by `tint`: the one built before for the same pixels, tint and
    /// colour space, else a new one.
    pub fn dome(&mut self, tex: &TextureDesc, tint: [f32; 3], cs: ColorSpace) -> Result<Arc<DomeMap>, String> {
        match self.map(true, tex, tint, cs, &|| Ok(Map::Dome(Arc::new(DomeMap::new(tex, tint, cs)?))))? {
            Map::Dome(m) => Ok(m),
            Map::Rect(_) => unreachable!("dome keys hold dome maps"),
        }
    }

    /// A rect light's map of `tex` tinted by `tint`, as [`MapSession::dome`].
    pub fn rect(&mut self, tex: &TextureDesc, tint: [f32; 3], cs: ColorSpace) -> Result<Arc<RectMap>, String> {
        match self.map(false, tex, tint, cs, &|| Ok(Map::Rect(Arc::new(RectMap::new(tex, tint, cs)?))))? {
            Map::Rect(m) => Ok(m),
            Map::Dome(_) => unreachable!("rect keys hold rect maps"),
        }
    }

    fn map(&mut self, dome: bool, tex: &TextureDesc, tint: [f32; 3], cs: ColorSpace, make: &dyn Fn() -> Result<Map, String>) -> Result<Map, String> {
        let key = Key { dome, width: tex.width, height: tex.height, channels: tex.channels, tint: tint.map(f32::to_bits), cs };
        if let Some(e) = self.kept.iter().find(|e| e.is(tex, key)) {
            return Ok(e.map.clone());
        }
        let map = match self.old.iter().position(|e| e.is(tex, key)) {
            Some(i) => self.old.swap_remove(i).map,
            None => make()?,
        };
        self.kept.push(Entry { pixels: tex.pixels.clone(), key, map: map.clone() });
        Ok(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::tests::{desc, hot_spot_texture};
    use crate::light::Light;
    use crate::scene::LightShape;
    use glam::Mat4;

    fn map_of(l: &Light) -> Arc<DomeMap> {
        let Light::Dome(d) = l else { panic!("not a dome") };
        d.map.clone().expect("a map")
    }

    #[test]
    fn a_build_takes_the_map_of_the_same_pixels_tint_and_colour_space() {
        let cs = ColorSpace::LinearRec709;
        let tex = vec![hot_spot_texture()];
        let dome = desc(LightShape::Dome { texture: Some(0) }, Mat4::IDENTITY);
        let build = |cache: &MapCache, tex: &[TextureDesc], descs: &[crate::scene::LightDesc]| {
            let mut s = cache.begin();
            let maps: Vec<_> = descs.iter().map(|d| map_of(&Light::from_desc_with(d, tex, cs, Some(&mut s)).unwrap())).collect();
            cache.end(s);
            maps
        };
        let cache = MapCache::default();
        let first = build(&cache, &tex, std::slice::from_ref(&dome));
        assert_eq!(*first[0], *map_of(&Light::from_desc(&dome, &tex, cs).unwrap()), "the same map as without a cache");
        // the next build shares it; two domes on one image share it too; a tint makes another
        let tinted = crate::scene::LightDesc { color: [1.0, 0.5, 0.5], ..dome.clone() };
        let second = build(&cache, &tex, &[dome.clone(), dome.clone(), tinted]);
        assert!(Arc::ptr_eq(&second[0], &first[0]) && Arc::ptr_eq(&second[1], &first[0]));
        assert!(!Arc::ptr_eq(&second[2], &first[0]));
        assert_eq!(cache.len(), 2);
        // the same texels in other pixels are another image: images are known by their pixels
        let copy = vec![TextureDesc { pixels: tex[0].pixels.to_f32(tex[0].channels as usize).into(), ..tex[0].clone() }];
        let third = build(&cache, &copy, std::slice::from_ref(&dome));
        assert!(!Arc::ptr_eq(&third[0], &first[0]));
        assert_eq!(*third[0], *first[0]);
        // a build without domes leaves the cache empty
        build(&cache, &tex, &[]);
        assert!(cache.is_empty());
    }

    #[test]
    fn rect_lights_keep_their_maps_apart_from_domes() {
        let cs = ColorSpace::LinearRec709;
        let tex = vec![hot_spot_texture()];
        let rect = desc(LightShape::Rect { width: 1.0, height: 2.0, texture: Some(0) }, Mat4::IDENTITY);
        let dome = desc(LightShape::Dome { texture: Some(0) }, Mat4::IDENTITY);
        let rect_map = |l: &Light| {
            let Light::Rect(r) = l else { panic!("not a rect") };
            r.map.clone().expect("a map")
        };
        let cache = MapCache::default();
        let build = |descs: &[crate::scene::LightDesc]| {
            let mut s = cache.begin();
            let lights: Vec<Light> = descs.iter().map(|d| Light::from_desc_with(d, &tex, cs, Some(&mut s)).unwrap()).collect();
            cache.end(s);
            lights
        };
        let first = build(&[rect.clone(), dome.clone()]);
        assert_eq!(cache.len(), 2, "a rect and a dome on one image make a map each");
        assert_eq!(*rect_map(&first[0]), *rect_map(&Light::from_desc(&rect, &tex, cs).unwrap()), "the same map as without a cache");
        // the next build shares both; a tinted rect makes another
        let tinted = crate::scene::LightDesc { color: [0.2, 1.0, 1.0], ..rect.clone() };
        let second = build(&[rect.clone(), dome.clone(), tinted]);
        assert!(Arc::ptr_eq(&rect_map(&second[0]), &rect_map(&first[0])) && Arc::ptr_eq(&map_of(&second[1]), &map_of(&first[1])));
        assert!(!Arc::ptr_eq(&rect_map(&second[2]), &rect_map(&first[0])));
        build(&[dome]);
        assert_eq!(cache.len(), 1);
    }
}
