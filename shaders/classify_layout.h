// Layout of the lookup buffer that shaders/classify.comp reads, included by both the shader and
// host/backend_vulkan.cpp (plain #defines: valid C++ and GLSL). The words themselves are filled
// at run time from core/mc33.h (mc33_config, kSubcaseInfo, kCubeEdges) and core/hex_faces.h, so
// core stays the one source of truth for the tables.
#ifndef MCHEX_SHADERS_CLASSIFY_LAYOUT_H
#define MCHEX_SHADERS_CLASSIFY_LAYOUT_H

// mc33_config(mask, face_joins) at mask * 64 + face_joins:
//   subcase | map[0] << 8 | map[1] << 16 | preferred << 24
#define MCHEX_TABLE_CONFIG 0
// Per subcase: tunnel_partner | (tunnel + 1) << 8
#define MCHEX_TABLE_SUBCASE 16384
// Per cube edge (Table 1 order): first corner | second corner << 8
#define MCHEX_TABLE_EDGES 16416
// Per hex face (kHexFaces): q0 | q1 << 8 | q2 << 16 | q3 << 24
#define MCHEX_TABLE_FACES 16428
#define MCHEX_TABLE_WORDS 16434

// A CellCode (host/backend.h) as two words:
//   word 0: subcase | sign_mask << 8 | face_joins << 16 | (tunnel + 1) << 24 | inverted << 26
//   word 1: symmetry | cut_edges << 16
#define MCHEX_CODE_SIGN_SHIFT 8
#define MCHEX_CODE_FACE_SHIFT 16
#define MCHEX_CODE_TUNNEL_SHIFT 24
#define MCHEX_CODE_INVERTED_SHIFT 26
#define MCHEX_CODE_CUT_SHIFT 16

#endif
