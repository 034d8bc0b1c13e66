// SPDX-License-Identifier: Apache-2.0
#pragma once
// Internal to lfi_sim: a Fresnel event at a dielectric interface — Snell's
// law, total internal reflection, the unpolarised Fresnel reflectance and
// both outgoing directions — written once for one ray and run over a
// packet's lanes at once (structure of arrays, vectorised). The one-ray walk
// and the packet renderer both use it, so they give the same bits.

#include "lfi/sim/scene.h"

#include <algorithm>
#include <cmath>

namespace lfi::sim::detail {

// Cosine of the transmitted angle (Snell) for incidence cosine cosI in [0, 1]
// and eta = n1 / n2; -1 under total internal reflection.
inline double transmittedCosine(double cosI, double eta) {
  const double sin2T = eta * eta * (1 - cosI * cosI), cos2T = 1 - sin2T;
  return sin2T >= 1 ? -1 : std::sqrt(cos2T);
}

// Unpolarised Fresnel reflectance from both angles' cosines: the mean of
// rs^2 and rp^2, rs = (a - b) / (a + b), rp = (c - d) / (c + d), over one
// division (a path's latency is mostly its divisions and roots).
inline double fresnelFromCosines(double cosI, double cosT, double n1, double n2) {
  const double a = n1 * cosI, b = n2 * cosT, c = n2 * cosI, d = n1 * cosT;
  const double rs = (a - b) * (c + d), rp = (c - d) * (a + b), denominator = (a + b) * (c + d);
  return 0.5 * (rs * rs + rp * rp) / (denominator * denominator);
}

// v, unit to within rounding, brought back to unit length: one Newton step for
// 1/sqrt(v.v) at 1, exact to second order in |v.v - 1| (~1e-16). Refraction
// and reflection of unit vectors give unit vectors but for rounding; this
// keeps the rounding from adding up along a path, without a root and a
// division on every bounce (they set a path's latency).
inline Vec3 renormalised(const Vec3& v) {
  return v * (1.5 - 0.5 * v.dot(v));
}

// A ray with unit direction d meets an interface with unit normal n (either
// side) from index n1 into index n2. In components and selects rather than
// branches, so that the lane-parallel loop below vectorises.
struct FresnelEvent {
  double cosT;         // cosine of the refraction angle; < 0 under total internal reflection
  double reflectance;  // of the interface (1 under total internal reflection)
  double rx, ry, rz;   // reflected direction, unit
  double tx, ty, tz;   // refracted direction, unit; meaningless under total internal reflection
};
inline FresnelEvent fresnelEvent(double dx, double dy, double dz, double nx, double ny, double nz, double n1,
                                 double n2) {
  const double side = dx * nx + dy * ny + dz * nz < 0 ? 1.0 : -1.0;
  const double fx = side * nx, fy = side * ny, fz = side * nz;  // the normal towards the incoming side
  const double dn = dx * fx + dy * fy + dz * fz;
  const double cosI = -dn < 0 ? 0.0 : (1 < -dn ? 1.0 : -dn), eta = n1 / n2;
  const double cosT = transmittedCosine(cosI, eta);
  FresnelEvent e;
  e.cosT = cosT;
  e.reflectance = cosT < 0 ? 1.0 : fresnelFromCosines(cosI, cosT, n1, n2);
  const double twice = 2 * dn, bend = eta * cosI - cosT;
  const double rx = dx - fx * twice, ry = dy - fy * twice, rz = dz - fz * twice;
  const double tx = dx * eta + fx * bend, ty = dy * eta + fy * bend, tz = dz * eta + fz * bend;
  const double rs = 1.5 - 0.5 * (rx * rx + ry * ry + rz * rz), ts = 1.5 - 0.5 * (tx * tx + ty * ty + tz * tz);
  e.rx = rx * rs, e.ry = ry * rs, e.rz = rz * rs;  // renormalised()
  e.tx = tx * ts, e.ty = ty * ts, e.tz = tz * ts;
  return e;
}
inline FresnelEvent fresnelEvent(const Vec3& d, const Vec3& n, double n1, double n2) {
  return fresnelEvent(d.x, d.y, d.z, n.x, n.y, n.z, n1, n2);
}

// The packet's Fresnel events, every lane at once (lanes not in use compute
// harmless values): lane k's ray `rays` meets the surface of `hits` from index
// n1[k] into n2[k]. Also gives the hit points, rays.ray(k).at(hits.t[k]).
struct FresnelLanes {
  static constexpr int kSize = static_cast<int>(Scene::kPacket);
  alignas(64) double n1[kSize], n2[kSize];             // in
  alignas(64) double px[kSize], py[kSize], pz[kSize];  // out: the hit points
  alignas(64) double cosT[kSize], reflectance[kSize];  // out: as FresnelEvent
  alignas(64) double rx[kSize], ry[kSize], rz[kSize];  // out: reflected
  alignas(64) double tx[kSize], ty[kSize], tz[kSize];  // out: refracted
};
void fresnelLanes(const RayLanes& rays, const Scene::HitPacket& hits, FresnelLanes& out);

// Lane k's event alone, as fresnelLanes computes it: for steps of one or two
// lanes (paths reflected inside a lens), where a pass over every lane costs more.
inline void fresnelLane(const RayLanes& __restrict rays, const Scene::HitPacket& __restrict hits,
                        FresnelLanes& __restrict out, int k) {
  const double dx = rays.dx[k], dy = rays.dy[k], dz = rays.dz[k], t = hits.t[k];
  const FresnelEvent e = fresnelEvent(dx, dy, dz, hits.nx[k], hits.ny[k], hits.nz[k], out.n1[k], out.n2[k]);
  out.px[k] = rays.ox[k] + dx * t, out.py[k] = rays.oy[k] + dy * t, out.pz[k] = rays.oz[k] + dz * t;
  out.cosT[k] = e.cosT, out.reflectance[k] = e.reflectance;
  out.rx[k] = e.rx, out.ry[k] = e.ry, out.rz[k] = e.rz;
  out.tx[k] = e.tx, out.ty[k] = e.ty, out.tz[k] = e.tz;
}

}  // namespace lfi::sim::detail
