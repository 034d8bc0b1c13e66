#include "fresnel_step.h"

#include "simd.h"

namespace lfi::sim::detail {

LFI_SIMD_CLONES void fresnelLanes(const RayLanes& __restrict rays, const Scene::HitPacket& __restrict hits,
                                  FresnelLanes& __restrict out) {
  for (int k = 0; k < FresnelLanes::kSize; ++k) {
    const double dx = rays.dx[k], dy = rays.dy[k], dz = rays.dz[k], t = hits.t[k];
    const FresnelEvent e = fresnelEvent(dx, dy, dz, hits.nx[k], hits.ny[k], hits.nz[k], out.n1[k], out.n2[k]);
    out.px[k] = rays.ox[k] + dx * t, out.py[k] = rays.oy[k] + dy * t, out.pz[k] = rays.oz[k] + dz * t;
    out.cosT[k] = e.cosT, out.reflectance[k] = e.reflectance;
    out.rx[k] = e.rx, out.ry[k] = e.ry, out.rz[k] = e.rz;
    out.tx[k] = e.tx, out.ty[k] = e.ty, out.tz[k] = e.tz;
  }
}

}  // namespace lfi::sim::detail
