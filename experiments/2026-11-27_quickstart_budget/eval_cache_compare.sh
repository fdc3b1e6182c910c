cd .
M=runs/short/C.seed0/stage2/model
for round in 1; do
for which in old new; do
  rm -rf /tmp/evalcmp/$which
  if [ $which = old ]; then PP=/tmp/oldsrc/src; else PP=src; fi
  s=$(date +%s.%N)
  PYTHONPATH=$PP .venv/bin/python -c "import sys; from tacreasoner.cli import main; sys.argv[0]='tacreasoner'; main()" evaluate --model $M --bench runs/qs/bench --split val --out /tmp/evalcmp/$which \
     --batch-size 48 --max-new-tokens 64 --video-cache runs/qs/video_cache > /tmp/evalcmp_$which.log 2>&1
  e=$(date +%s.%N); echo "$which $(echo "$e - $s" | bc)"
done; done
