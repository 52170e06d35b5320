// module synth
