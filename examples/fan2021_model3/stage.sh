#!/bin/sh
# Stages the Fan et al. 2021 model3 pothole pairs as a ready-to-run survey in DEST: DEST/frames in the plain
# layout (left/N.png and right/N.png are links to the data's "left images/LN.png" and "right images/RN.png",
# nothing is copied; timestamps.csv puts the independent pairs 1 s apart) and DEST/survey.json (this folder's
# survey.json). The data folder is $ROADSURVEY_DATA, else ../shared/data beside the checkout.
set -eu
dest=${1:?usage: stage.sh DEST_DIR}
here=$(cd "$(dirname "$0")" && pwd)
data=${ROADSURVEY_DATA:-$here/../../../shared/data}
if [ ! -d "$data/pothole_recon_fan2021/model3" ]; then
  echo "stage.sh: $data/pothole_recon_fan2021/model3 is not a folder; set ROADSURVEY_DATA to the data folder" >&2
  exit 2
fi
src=$(cd "$data/pothole_recon_fan2021/model3" && pwd)
mkdir -p "$dest/frames/left" "$dest/frames/right"
echo "filename,t_ns" > "$dest/frames/timestamps.csv"
for i in 1 2 3 4 5; do
  ln -sfn "$src/left images/L$i.png" "$dest/frames/left/$i.png"
  ln -sfn "$src/right images/R$i.png" "$dest/frames/right/$i.png"
  echo "$i.png,${i}000000000" >> "$dest/frames/timestamps.csv"
done
cp "$here/survey.json" "$dest/survey.json"
echo "staged 5 pairs in $dest/frames; next: roadsurvey validate $dest/survey.json && roadsurvey run $dest/survey.json"
