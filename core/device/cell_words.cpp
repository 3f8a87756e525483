#include "core/device/cell_words.h"

#include "core/cutting/local_refinement.h"
#include "core/cutting/mc33.h"

namespace mchex {

std::vector<uint32_t> packed_mc33_configs() {
  std::vector<uint32_t> words(kConfigWords);
  for (int mask = 0; mask < 256; ++mask)
    for (int faces = 0; faces < 64; ++faces) {
      const Mc33Config& c = mc33_config(uint8_t(mask), uint8_t(faces));
      words[mask * 64 + faces] = uint32_t(c.subcase) | uint32_t(c.map[0]) << kConfigMap0Shift |
                                 uint32_t(c.map[1]) << kConfigMap1Shift |
                                 uint32_t(c.preferred) << kConfigPreferredShift;
    }
  for (int s = 0; s < kNumSubcases; ++s) {
    const auto& info = kSubcaseInfo[s];
    words.push_back(uint32_t(info.tunnel_partner) | uint32_t(info.tunnel + 1) << kConfigTunnelShift |
                    uint32_t(local_refinement_hexes(Subcase(s))) << kConfigHexesShift);
  }
  return words;
}

}  // namespace mchex
