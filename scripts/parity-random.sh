#!/bin/sh
# Random parity scenes (make stress): N small scenes drawn from the whole
# scene format, each compared with POV-Ray's render of its export by
# scripts/parity.sh. What the suite's scenes do not pin down: cameras from
# a field of 0.5 to 175 degrees, tilted up vectors and camera paths; scenes
# 10^3 to 3x10^4 from the origin; point, area, adaptive, fading and
# shadowless lights; every primitive, transformed; mirrors, depth limits
# and supersampling. Left out are the differences that parity.md explains:
# transparent solids that cut each other (POV-Ray's shadow rays stop at two
# surfaces 10^-3 apart), PN patches (POV-Ray gets a tessellation) and
# adaptive anti-aliasing (the reference samples every pixel).
#
#   sh scripts/parity-random.sh [LANCER] [N] [FIRST_SEED]
#
# Scenes go to build/parity-random/sSEED.scn; a failure names its scene,
# which reproduces alone with scripts/parity.sh. Exits non-zero if any failed.
set -u
LANCER=${1:-build/lancer}
N=${2:-200}
FIRST=${3:-1}
DIR=build/parity-random
MESH=../../scenes/parity/icosahedron.off # from $DIR
mkdir -p "$DIR"
rm -f "$DIR"/s*.scn
seed=$FIRST
while [ "$seed" -lt $((FIRST + N)) ]; do
    awk -v seed="$seed" -v mesh="$MESH" '
    function u(a, b) { return a + (b - a) * rand() }
    function ri(a, b) { return a + int((b - a + 1) * rand()) }
    function v(a, b) { return sprintf("%.4g %.4g %.4g", u(a, b), u(a, b), u(a, b)) }
    function at(x, y, z) { return sprintf("%.9g %.9g %.9g", x + O[1], y + O[2], z + O[3]) }
    function vo(a, b) { return at(u(a, b), u(a, b), u(a, b)) }
    function shell(   r, th, ph) {
        r = u(5, 14); th = u(0, 6.2831853); ph = u(-0.3, 1.2)
        return at(r * cos(ph) * cos(th), r * sin(ph) + 0.5, r * cos(ph) * sin(th))
    }
    function fov(   x) { x = rand(); return x < 0.15 ? u(0.5, 5) : x < 0.3 ? u(120, 175) : u(15, 80) }
    function mat() { return "m" ri(0, nm - 1) }
    function xf(   s) {
        s = ""
        if (rand() < 0.2) s = s sprintf("  scale %.3g %.3g %.3g", u(0.5, 1.5), u(0.5, 1.5), u(0.5, 1.5))
        if (rand() < 0.3) s = s "  rotate " v(-90, 90)
        return s "  translate " at(0, 0, 0)
    }
    BEGIN {
        srand(seed)
        for (i = 1; i <= 3; i++) O[i] = rand() < 0.25 ? (rand() < 0.5 ? -1 : 1) * u(1e3, 3e4) : 0
        w = ri(96, 160); h = ri(96, 160)
        spp = rand() < 0.25 ? " spp " ri(2, 3) : ""
        printf "image { width %d height %d background %s max_depth %d%s }\n", w, h, v(0, 0.8), ri(1, 6), spp
        up = rand() < 0.3 ? "  up " v(-1, 1) : ""
        printf "camera { eye %s  target %s  fov %.4g%s }\n", shell(), vo(-1, 1), fov(), up
        if (rand() < 0.2) {
            f = 0
            for (k = ri(2, 4); k > 0; k--) {
                printf "keyframe { frame %d  eye %s  target %s  fov %.3g }\n", f, shell(), vo(-1, 1), u(20, 70)
                last = f; f += ri(3, 20)
            }
            printf "# parity-frame: %d\n", ri(0, last + 5)
        }
        for (k = ri(1, 3); k > 0; k--) {
            s = sprintf("light { position %s  color %s", at(u(-8, 8), u(2, 10), u(-8, 8)), v(0.2, 1))
            if (rand() < 0.25) s = s sprintf("  fade_distance %.3g fade_power %d", u(2, 10), ri(1, 2))
            x = rand()
            if (x < 0.1) s = s "  shadowless"
            else if (x < 0.4) {
                s = s sprintf("  area_u %s  area_v %s  area_samples %d %d", v(-1, 1), v(-1, 1), ri(2, 5), ri(2, 5))
                if (rand() < 0.3) s = s "  area_adaptive " ri(0, 2)
            }
            print s " }"
        }
        nm = ri(2, 5)
        for (k = 0; k < nm; k++) {
            s = sprintf("material m%d { color %s ambient %.2g diffuse %.2g", k, v(0.05, 1), u(0, 0.2), u(0, 0.9))
            if (rand() < 0.5) s = s sprintf(" phong %.2g phong_size %d", u(0, 1), ri(5, 200))
            if (rand() < 0.3) s = s sprintf(" specular %.2g roughness %.3g", u(0, 1), u(0.005, 0.2))
            if (rand() < 0.35) s = s sprintf(" reflection %.2g", u(0, 0.8))
            print s " }"
        }
        if (rand() < 0.8)
            printf "plane { normal %.3g 1 %.3g  offset %.3g  material %s%s }\n", u(-0.2, 0.2), u(-0.2, 0.2), u(-1.5, -0.5), mat(), xf()
        for (k = ri(2, 8); k > 0; k--) {
            x = ri(1, 7)
            if (x <= 2)
                printf "sphere { center %s  radius %.3g  material %s%s }\n", v(-3, 3), u(0.3, 1.5), mat(), xf()
            else if (x == 3) {
                a1 = u(-3, 2); a2 = u(-3, 2); a3 = u(-3, 2)
                printf "box { min %.3g %.3g %.3g  max %.3g %.3g %.3g  material %s%s }\n", a1, a2, a3, a1 + u(0.2, 2), a2 + u(0.2, 2), a3 + u(0.2, 2), mat(), xf()
            } else if (x == 4)
                printf "obox { center %s  u %s  v %s  w %s  material %s%s }\n", v(-3, 3), v(-1, 1), v(-1, 1), v(-1, 1), mat(), xf()
            else if (x == 5)
                printf "triangle { a %s  b %s  c %s  material %s%s }\n", v(-3, 3), v(-3, 3), v(-3, 3), mat(), xf()
            else if (x == 6)
                printf "smooth_triangle { a %s  b %s  c %s  na %s  nb %s  nc %s  material %s%s }\n", v(-3, 3), v(-3, 3), v(-3, 3), v(-1, 1), v(-1, 1), v(-1, 1), mat(), xf()
            else
                printf "mesh { file \"%s\"  %s  scale %.3g  translate %s  material %s }\n", mesh, rand() < 0.5 ? "flat" : "smooth", u(0.5, 1.5), vo(-3, 3), mat()
        }
    }' >"$DIR/s$seed.scn"
    seed=$((seed + 1))
done
LANCER_PARITY_OUT=$DIR/out sh scripts/parity.sh "$LANCER" "$DIR"/s*.scn
