#!/bin/sh
# Records the fixture sessions under fixtures/sessions/: simulated traffic
# (acq simulate) on vcans named like the rigs' buses, recorded by acq record
# exactly as at the machine. Run from the host with
#   fixtures/sessions/record-all
# ($IN holds rigs/, dbc/, scenarios/ and data/ as in the repository).
set -eu
OUT=${OUT:-/out}
IN=${IN:-/in}

for dev in can0 can1; do
    ip link add dev "$dev" type vcan 2>/dev/null || true
    ip link set up "$dev"
done

wait_for_session() {
    i=0
    while [ ! -f "$1/session.toml" ]; do
        i=$((i + 1))
        [ $i -lt 300 ] || { echo "recorder did not start: $1"; exit 1; }
        sleep 0.1
    done
}

# record NAME RIG SCENARIO SEED IFACE...
# $ONLY (space-separated names), when set, limits the run to those sessions.
record() {
    name=$1 rig=$2 scenario=$3 seed=$4
    shift 4
    case " ${ONLY:-$name} " in *" $name "*) ;; *) return 0 ;; esac
    args=""
    for dev in "$@"; do args="$args --iface $dev"; done
    acq record $args --rig "$IN/rigs/$rig" --out "$OUT/$name" --quiet &
    rec=$!
    wait_for_session "$OUT/$name"
    acq simulate --rig "$IN/rigs/$rig" --scenario "$IN/scenarios/$scenario" $args --seed "$seed"
    sleep 0.5
    kill -INT $rec
    wait $rec
    echo "recorded $name"
}

record excavator_case1 excavator.toml excavator_case1.toml 101 can0 can1
record excavator_case2 excavator.toml excavator_case2.toml 102 can0 can1
record tensile_p91_20c tensile.toml tensile_p91_20c.toml 103 can0
