#!/bin/sh
# The targets of make bench against what it measured: reads the lines
# "target<TAB>case<TAB>value" that the benchmarks appended to RESULTS and
# prints one Markdown table, a row per target: its goal, how many cases
# meet it, the worst case and the median. Names the processor first: the
# figures depend on it (Embree picks its code by the instruction set).
#   sh scripts/bench-table.sh RESULTS
set -eu
results=$1
echo "Processor: $(sed -n 's/^model name[^:]*: //p' /proc/cpuinfo | head -n 1)," \
    "$(nproc) cores; AVX2: $(grep -qw avx2 /proc/cpuinfo && echo yes || echo no)," \
    "AVX-512: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no);" \
    "family $(sed -n 's/^cpu family[^:]*: //p' /proc/cpuinfo | head -n 1)," \
    "model $(sed -n 's/^model[^:n]*: //p' /proc/cpuinfo | head -n 1)"
echo
echo "| target | goal | cases met | worst case | median |"
echo "| --- | --- | --- | --- | --- |"
# target, goal direction (ge: at least, le: at most), goal, what it measures
awk -F'\t' '
    BEGIN {
        n = split("camera shadow diffuse-single stream packet build faults memory mirror frame scaling pn-exact pn-memory pn-fast pn-tess-memory", order, " ")
        d["camera"] = "ge 1.5 camera rays, lancer / Embree robust (rtcIntersect1)"
        d["shadow"] = "ge 1.5 shadow rays, lancer / Embree robust (rtcOccluded1)"
        d["diffuse-single"] = "ge 1.2 diffuse rays one by one, lancer / Embree robust (rtcIntersect1)"
        d["stream"] = "ge 1.2 diffuse rays as one stream, sorted first, lancer / Embree robust (rtcIntersect1)"
        d["packet"] = "ge 1.0 camera rays in packets of 8, lancer / Embree robust (rtcIntersect8)"
        d["build"] = "le 0.8 BVH build time, lancer / the faster Embree medium build"
        d["faults"] = "le 1.0 page faults, most in one build, lancer / Embree"
        d["memory"] = "le 1.0 BVH bytes per triangle, lancer / the smaller Embree"
        d["mirror"] = "ge 10 bunny mirror frame, POV-Ray trace / lancer render"
        d["frame"] = "ge 3 parity scenes, POV-Ray trace / lancer render, equal threads"
        d["scaling"] = "ge 1.9 lancer render time, 1 thread / 2 threads"
        d["pn-exact"] = "le 8 PN exact mode / flat triangles, render time"
        d["pn-memory"] = "le 3 PN mesh / flat triangles, peak memory"
        d["pn-fast"] = "ge 1 tessellation at fast mode\x27s error / fast mode, build + render"
        d["pn-tess-memory"] = "le 0.5 PN mesh / that tessellation, peak memory"
    }
    { v[$1, ++c[$1]] = $3; k[$1, c[$1]] = $2 }
    END {
        for (i = 1; i <= n; i++) {
            t = order[i]
            split(d[t], w, " ")
            what = substr(d[t], length(w[1]) + length(w[2]) + 3)
            if (!(t in c)) { printf "| %s | %s %s | not measured | | |\n", what, (w[1] == "ge" ? "≥" : "≤"), w[2]; continue }
            met = 0; worst = ""
            for (j = 1; j <= c[t]; j++) {
                # a NaN (0 / 0) meets no goal and is the worst, which awk,
                # comparing it as true, would not make it
                x = v[t, j]; val = (x == "inf") ? 1e300 : (x ~ /nan/) ? (w[1] == "ge" ? -1e300 : 1e300) : x + 0
                ok = (w[1] == "ge") ? val >= w[2] : val <= w[2]
                met += ok
                bad = (w[1] == "ge") ? -val : val
                if (worst == "" || bad > worstbad) { worst = j; worstbad = bad }
                s[j] = val
            }
            # the median, by insertion sort
            for (a = 2; a <= c[t]; a++) { y = s[a]; for (b = a - 1; b >= 1 && s[b] > y; b--) s[b + 1] = s[b]; s[b + 1] = y }
            m = (c[t] % 2) ? s[(c[t] + 1) / 2] : (s[c[t] / 2] + s[c[t] / 2 + 1]) / 2
            if (m > 1e299) m = 1e300 # the mean of an infinity and a number: an infinity
            if (m < -1e299) m = -1e300
            printf "| %s | %s %s | %d of %d%s | %s (%s) | %s |\n", what, (w[1] == "ge" ? "≥" : "≤"), w[2], met, c[t],
                (met == c[t] ? " **met**" : ""), (v[t, worst] == "inf" ? "∞" : sprintf("%.2f", v[t, worst])), k[t, worst],
                (m >= 1e300 ? "∞" : m <= -1e300 ? "nan" : sprintf("%.2f", m))
        }
    }' "$results"
