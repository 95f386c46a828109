#pragma once
// Everything for reading and writing meshes: read_mesh / write_mesh pick PLY or OBJ by extension.
#include "pg/mesh/obj_io.h"
#include "pg/mesh/ply_io.h"
