//! Paths for bidirectional estimators (Veach 1997, ch. 10; the path-space formulation of the
//! overview paper §2–4): vertices with forward and reverse area-measure densities, camera and light
//! random walks driven by a sample stream, `(s, t)` connections and their MIS weights. The same
//! structures serve BDPT, PSSMLT, MMLT and the technique charts of charted MLT.

mod connect;
mod mis;
mod subpath;
mod vertex;
mod walk;

pub use connect::{
    Connection, End, EndPairs, GRAZING_COSINE, connect, connect_unoccluded, geometry, join,
    unoccluded,
};
pub use mis::{DELTA_DENSITY, MisHeuristic, mis_weight};
pub use subpath::Subpath;
pub use vertex::{Vertex, VertexKind};
pub use walk::{
    Roulette, WalkSettings, camera_ray, camera_subpath, camera_subpath_with, light_subpath,
    light_subpath_with, technique_subpaths, technique_subpaths_every_length,
};
