// bvhlab's C interface to tinybvh's BVH8_CPU (see README.md): a build over a triangle soup
// and the two single-ray queries. A ray's (tmin, tmax) is taken by starting it at tmin
// (tinybvh's rays start at their origin) and giving it tmax - tmin; the direction is used
// as given, unnormalised, so that t means what it means in bvhlab.
#define TINYBVH_IMPLEMENTATION
#include "tiny_bvh.h"

#include <cstdint>
#include <cstring>
#include <vector>

namespace {
struct Peer {
	std::vector<tinybvh::bvhvec4> vertices; // the BVH reads them while it traces
	tinybvh::BVH8_CPU bvh;
};

tinybvh::Ray make_ray(const float* r) {
	// r: origin xyz, direction xyz, tmin, tmax. The constructor normalises the direction;
	// bvhlab's is put back (tinybvh's queries work with any length), so t is bvhlab's t.
	tinybvh::bvhvec3 d(r[3], r[4], r[5]);
	tinybvh::bvhvec3 o(r[0] + d.x * r[6], r[1] + d.y * r[6], r[2] + d.z * r[6]);
	tinybvh::Ray ray(o, d, r[7] - r[6]);
	ray.D = d;
	ray.rD = tinybvh::tinybvh_rcp(d);
	return ray;
}
} // namespace

extern "C" {

// Builds over `count` triangles of nine floats each; `hq` takes tinybvh's SBVH
// (BuildHQ), otherwise its default build. Null if the header was built without AVX2.
void* bvhlab_tinybvh_build(const float* triangles, uint32_t count, int hq) {
#ifdef BVH_USEAVX2
	Peer* p = new Peer();
	p->vertices.resize(size_t(count) * 3);
	for (size_t i = 0; i < size_t(count) * 3; i++)
		p->vertices[i] = tinybvh::bvhvec4(triangles[3 * i], triangles[3 * i + 1], triangles[3 * i + 2], 0);
	if (hq)
		p->bvh.BuildHQ(p->vertices.data(), count);
	else
		p->bvh.Build(p->vertices.data(), count);
	return p;
#else
	(void)triangles; (void)count; (void)hq;
	return nullptr;
#endif
}

// The closest hit of one ray: 1 and (t, u, v, triangle) if there is one.
int bvhlab_tinybvh_intersect(const void* peer, const float* ray, float* t, float* u, float* v, uint32_t* prim) {
	const Peer* p = static_cast<const Peer*>(peer);
	tinybvh::Ray r = make_ray(ray);
	const float far = r.hit.t;
	p->bvh.Intersect(r);
	if (!(r.hit.t < far)) return 0;
	*t = r.hit.t + ray[6];
	*u = r.hit.u;
	*v = r.hit.v;
	*prim = r.hit.prim;
	return 1;
}

int bvhlab_tinybvh_occluded(const void* peer, const float* ray) {
	const Peer* p = static_cast<const Peer*>(peer);
	return p->bvh.IsOccluded(make_ray(ray)) ? 1 : 0;
}

void bvhlab_tinybvh_free(void* peer) { delete static_cast<Peer*>(peer); }

} // extern "C"
