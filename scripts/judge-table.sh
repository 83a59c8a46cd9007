#!/bin/sh
# Turns the exact judge's "exact:" lines into a markdown table, one row per
# case and routine: rays, false misses, false hits, disagreements outside
# the routine's band, t's error in ulps (median, 99th percentile), and hits
# whose exact t lies outside their own bound.
#   build/exact/judge 1000000 | sh scripts/judge-table.sh
set -eu
echo "| case | routine | rays | false miss | false hit | outside band | t ulp p50 | t ulp p99 | t bound fail |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
grep '^exact: ' | awk '{
    v["rays"] = v["false_miss"] = v["false_hit"] = v["outside_band"] = v["t_ulp_p50"] = v["t_ulp_p99"] = v["t_bound_fail"] = "";
    for (i = 4; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] }
    printf "| %s | `%s` | %s | %s | %s | %s | %s | %s | %s |\n", $2, $3, v["rays"], v["false_miss"], v["false_hit"],
           v["outside_band"], v["t_ulp_p50"], v["t_ulp_p99"], v["t_bound_fail"]
}'
