#version 450
#extension GL_GOOGLE_include_directive : require
#define RELIEF_MESH 1
#include "terrain_tese.glsl"
