#!/usr/bin/env bash
# The Unity package's core assembly (Examples/unity/com.coloc.xr) under Debian's mono: compiled
# with mcs against NUnit 2.6 and run by nunit-console against this build's
# libcoloc_fusion_c / libcoloc_localize_c and its coloc binary. Exit 77 (skipped) without mono.
#
# The fixture, a twin room registered to its scan, is made once per build tree (the same chain
# as `coloc demo`: twin generate, scan-markers, map, register --level markers) and reused.
set -euo pipefail

while [[ $# -gt 0 ]]; do
  case "$1" in
    --package) package=$2 ;;
    --probe) probe_source=$2 ;;
    --coloc) coloc=$2 ;;
    --libs) libs=$2 ;;
    --vocabulary) vocabulary=$2 ;;
    --work) work=$2 ;;
    *) echo "run_unity_tests: unknown argument $1" >&2; exit 2 ;;
  esac
  shift 2
done

for tool in mono mcs nunit-console; do
  if ! command -v "$tool" >/dev/null; then
    echo "skipped: $tool not found (Debian's mono-devel and nunit-console; scripts/install_deps.sh)"
    exit 77
  fi
done
nunit_dll=$(ls /usr/lib/cli/nunit.framework-2.*/nunit.framework.dll 2>/dev/null | head -n 1 || true)
if [[ -z "$nunit_dll" ]]; then
  echo "skipped: nunit.framework.dll not found (Debian's nunit-console)"
  exit 77
fi

start=$(date +%s)
bin="$work/bin"
mkdir -p "$bin"
# Warnings are errors here too; -langversion stays at what both mcs and Unity 2021.3 accept.
mcs -warnaserror -target:library -out:"$bin/Coloc.Core.dll" "$package"/Runtime/Core/*.cs
mcs -warnaserror -target:library -r:"$bin/Coloc.Core.dll" -r:"$nunit_dll" \
  -out:"$bin/Coloc.Core.Tests.dll" "$package"/Tests/Core/*.cs
mcs -warnaserror -r:"$bin/Coloc.Core.dll" -out:"$bin/MissingLibraryProbe.exe" "$probe_source"
# The MonoBehaviours, type-checked against a stub of the UnityEngine API they use (not run).
mcs -warnaserror -target:library -out:"$bin/UnityEngine.dll" "$(dirname "$probe_source")/UnityEngineStub.cs"
mcs -warnaserror -target:library -r:"$bin/Coloc.Core.dll" -r:"$bin/UnityEngine.dll" \
  -out:"$bin/Coloc.Unity.dll" "$package"/Runtime/Unity/*.cs
cp "$nunit_dll" "$bin/"

fixture="$work/fixture/twin_room_s1_10s_v1"
(
  # One builder at a time (ctest -j, or two build trees' tests), the others wait and reuse.
  flock 9
  if [[ ! -f "$fixture/done" ]]; then
    rm -rf "$fixture"
    mkdir -p "$fixture"
    echo "run_unity_tests: making the fixture (twin room, its map registered to the scan)"
    "$coloc" twin generate --preset room --seed 1 --seconds 10 --face-size 1024 \
      --out "$fixture/twin" --json >"$fixture/twin.json"
    "$coloc" scan-markers "$fixture/twin/scan/scan.e57" --dictionary DICT_4X4_50 --size 0.1675 \
      --out "$fixture/markers.yaml" >"$fixture/scan_markers.log"
    # Sequential: the same map (and markers seen) on every machine, whatever its load.
    "$coloc" map --sequence "$fixture/twin/sequence" --vocabulary "$vocabulary" --sequential \
      --trajectory "$fixture/trajectory.txt" --save "$fixture/map.db" --json >"$fixture/map.json"
    "$coloc" register --map "$fixture/map.db" --markers "$fixture/markers.yaml" \
      --out "$fixture/site.db" --level markers --json >"$fixture/register.json"
    touch "$fixture/done"
  fi
) 9>"$work/fixture.lock"
fixture_done=$(date +%s)

figures="$work/figures.txt"
# The tests' scratch folders (Path.GetTempPath follows TMPDIR): inside the build, renewed per run.
rm -rf "$work/tmp"
mkdir -p "$work/tmp"
: >"$figures"
status=0
(
  cd "$bin"
  LD_LIBRARY_PATH="$libs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
    COLOC_BIN="$coloc" COLOC_UNITY_FIXTURE="$fixture" COLOC_VOCABULARY="$vocabulary" \
    COLOC_UNITY_PROBE="$bin/MissingLibraryProbe.exe" COLOC_UNITY_FIGURES="$figures" TMPDIR="$work/tmp" \
    nunit-console -nologo -noshadow Coloc.Core.Tests.dll -xml="$work/TestResult.xml"
) || status=$?
echo "run_unity_tests: figures"
sed 's/^/  /' "$figures"
echo "run_unity_tests: compile and fixture $((fixture_done - start)) s, tests $(($(date +%s) - fixture_done)) s, exit $status"
exit "$status"
