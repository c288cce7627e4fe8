# A seated spring's deflection at two loads: u = F / k + d + s F^2 (mm, kN).
# Arguments: k (kN/mm), d (mm, the seating offset), the two loads (kN), s
# (1/kN: the softening). Writes out.json in the run directory.
awk -v k="$1" -v d="$2" -v f1="$3" -v f2="$4" -v s="$5" 'BEGIN {
    printf "{\"u_low_mm\": %.17g, \"u_high_mm\": %.17g}\n", f1 / k + d + s * f1 * f1, f2 / k + d + s * f2 * f2
}' > out.json
